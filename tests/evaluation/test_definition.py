"""A callable's digest follows what it computes: code, parameters, closure and globals read."""

from __future__ import annotations

from functools import partial

import numpy as np

from grouptron.evaluation import metrics
from grouptron.evaluation.definition import definition_digest

SCALE = 1.0


def _scaled(pred: np.ndarray, truth: np.ndarray, factor: float = 1.0) -> np.ndarray:
    return SCALE * factor * metrics.fde(pred, truth)


class _Threshold:
    def __init__(self, limit_m: float) -> None:
        self.limit_m = limit_m

    def __call__(self, pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
        return metrics.fde(pred, truth) > self.limit_m


def _closure(limit_m: float):
    return lambda pred, truth: metrics.fde(pred, truth) > limit_m


def test_equal_definitions_have_equal_digests_and_any_change_another() -> None:
    global SCALE
    same = [
        (metrics.ade, metrics.ade),
        (_closure(1.0), _closure(1.0)),
        (_Threshold(1.0), _Threshold(1.0)),
        (partial(_scaled, factor=2.0), partial(_scaled, factor=2.0)),
    ]
    for a, b in same:
        assert definition_digest(a) == definition_digest(b)
    different = [
        (metrics.ade, metrics.fde),
        (_closure(1.0), _closure(2.0)),
        (_Threshold(1.0), _Threshold(2.0)),
        (partial(_scaled, factor=2.0), partial(_scaled, factor=3.0)),
        (metrics.Metric("m", "m", _closure(1.0)), metrics.Metric("m", "m", _closure(2.0))),
    ]
    for a, b in different:
        assert definition_digest(a) != definition_digest(b)
    before = definition_digest(_scaled)
    SCALE = 2.0  # a module constant the function reads
    try:
        assert definition_digest(_scaled) != before
    finally:
        SCALE = 1.0
    assert definition_digest(_scaled) == before


def test_a_cycle_of_references_ends() -> None:
    loop: list[object] = []
    loop.append(loop)
    assert len(definition_digest(loop)) == 64
