"""Scores kept between reports: read back unchanged, and never served once anything changed."""

from __future__ import annotations

import dataclasses
import sys
from functools import partial
from pathlib import Path
from types import FrameType

import numpy as np
import pytest
import torch

import grouptron
from grouptron.config import ExperimentConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation import metrics, score_cache
from grouptron.evaluation.evaluate import score_samples
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.evaluation.score_cache import cached_score_samples, scoring_sources
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import build_model, groups_for_model, load_weights
from grouptron.reporting.report import ReportCheckpoint, ReportSettings, score_checkpoint
from tests.helpers.data import eth_test_samples

MODES = ("ml", "best-of-20")
MODES_ALL = ("ml", "mean", "ml-argmax", "ml-top10", "best-of-20", "nll")
EthTest = tuple[TrajectronCVAE, ExperimentConfig, SampleSet]


@pytest.fixture
def eth(tiny_checkpoints: Path, synthetic_data_dir: Path) -> EthTest:
    """A fresh copy of the tiny eth model (one test changes its weights) and its test set."""
    return eth_test_samples(tiny_checkpoints, synthetic_data_dir)


def _count_scored(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, ...]]:
    """The modes of every call that really scores (a cache miss)."""
    calls: list[tuple[str, ...]] = []

    def counting(*args, **kwargs):
        calls.append(tuple(args[3]))
        return score_samples(*args, **kwargs)

    monkeypatch.setattr(score_cache, "score_samples", counting)
    return calls


def test_cached_scores_are_read_back_unchanged_and_only_missing_modes_are_scored(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    first = cached_score_samples(tmp_path, model, config, samples, MODES, batch_size=7)
    again = cached_score_samples(tmp_path, model, config, samples, (*MODES, "mean"), batch_size=7)
    assert calls == [("ml",), ("best-of-20",), ("mean",)]  # each mode stored when scored
    cached_score_samples(tmp_path, model, config, samples, ("mean", "ml-argmax", "ml"))
    assert calls[3:] == [("ml", "mean"), ("ml-argmax",)]  # ml and mean share their decode
    fresh = score_samples(model, config, samples, (*MODES, "mean"), batch_size=7)
    for stored, direct in zip((*first, *again), (*fresh[:2], *fresh), strict=True):
        assert stored.mode == direct.mode
        for name in ("ade", "fde", "nll"):
            np.testing.assert_array_equal(getattr(stored, name), getattr(direct, name))


def test_any_change_of_weights_samples_or_settings_scores_again(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    cached_score_samples(tmp_path, model, config, samples, ("ml",))
    cached_score_samples(tmp_path, model, config, samples, ("ml",), batch_size=5)
    cached_score_samples(tmp_path, model, config, samples, ("ml",), ablate=("edges",))
    cached_score_samples(tmp_path, model, config, samples, ("best-of-20",), seed=0)
    cached_score_samples(tmp_path, model, config, samples, ("best-of-20",), seed=1)
    moved = dataclasses.replace(samples, fut_rel_m=samples.fut_rel_m + 0.01)
    cached_score_samples(tmp_path, model, config, moved, ("ml",))
    reseeded = dataclasses.replace(config, train=dataclasses.replace(config.train, seed=5))
    cached_score_samples(tmp_path, model, reseeded, samples, ("ml",))
    with torch.no_grad():
        next(model.parameters()).add_(1e-3)
    cached_score_samples(tmp_path, model, config, samples, ("ml",))
    assert len(calls) == 8
    cached_score_samples(tmp_path, model, config, samples, ("ml",))  # the last one, kept
    assert len(calls) == 8


def test_region_scores_are_kept_per_q_and_calibration(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    q90, q50 = RegionScoring((0.9,)), RegionScoring((0.5,))
    calibrated = RegionScoring((0.9,), {0.9: np.full(12, 2.0)})
    modes = ("ml-argmax", "best-of-20")
    (first, _) = cached_score_samples(tmp_path, model, config, samples, modes, regions=q90)
    for regions in (q50, calibrated, None, q90):
        cached_score_samples(tmp_path, model, config, samples, ("ml-argmax",), regions=regions)
    assert calls == [
        ("ml-argmax",),
        ("best-of-20",),
        ("ml-argmax",),
        ("ml-argmax",),
        ("ml-argmax",),
    ]
    (again,) = cached_score_samples(tmp_path, model, config, samples, ("ml-argmax",), regions=q90)
    assert len(calls) == 5  # q = 0.9's scores read back, per step
    fresh = score_samples(model, config, samples, ("ml-argmax",), regions=q90)[0]
    for name in ("coverage-q90", "area-q90"):
        np.testing.assert_array_equal(again.per_step[name], fresh.per_step[name])
        np.testing.assert_array_equal(first.per_step[name], fresh.per_step[name])
        np.testing.assert_array_equal(again.get(name), fresh.get(name))
        assert fresh.per_step[name].shape == (len(samples), 12)


def test_other_groups_score_again(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    model, config = load_trained_model(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    samples = load_part(synthetic_data_dir, "eth", "test", config.data).samples
    groups = groups_for_model(samples, config)
    assert groups is not None
    calls = _count_scored(monkeypatch)
    cached_score_samples(tmp_path, model, config, samples, ("ml",), groups=groups)
    together = dataclasses.replace(  # everyone in one group
        groups, ego_group=0 * groups.ego_group, nbr_group=0 * groups.nbr_group
    )
    assert groups.nbr_group.any()
    cached_score_samples(tmp_path, model, config, samples, ("ml",), groups=together)
    cached_score_samples(tmp_path, model, config, samples, ("ml",), groups=groups)
    assert len(calls) == 2


def test_unreadable_or_mismatched_cache_files_are_scored_again(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    (first,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    (stored,) = tmp_path.glob("*/*.npz")
    calls = _count_scored(monkeypatch)
    whole = stored.read_bytes()
    damaged = [b"not an npz", whole[:-10], whole[: len(whole) // 2]]
    for content in damaged:
        stored.write_bytes(content)
        (again,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
        np.testing.assert_array_equal(first.fde, again.fde)
    np.savez(stored, ade=first.ade[:3], fde=first.fde[:3], nll=first.nll[:3])
    (third,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    np.testing.assert_array_equal(first.fde, third.fde)
    assert len(calls) == len(damaged) + 1
    assert stored.read_bytes() == whole  # scored again and stored again


def test_a_sampling_mode_scores_the_same_whichever_modes_come_before_it(eth: EthTest) -> None:
    model, config, samples = eth
    few = samples.subset(np.arange(len(samples)) < 6)
    _, nll_after = score_samples(model, config, few, ("best-of-20", "nll"), batch_size=64)
    (nll_alone,) = score_samples(model, config, few, ("nll",), batch_size=64)
    np.testing.assert_array_equal(nll_after.nll, nll_alone.nll)


def test_every_module_that_runs_while_a_model_is_built_and_scored_is_in_the_key(
    tiny_checkpoints: Path, synthetic_data_dir: Path
) -> None:
    stored, config = load_trained_model(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    samples = load_part(synthetic_data_dir, "eth", "test", config.data).samples
    samples = samples.subset(np.arange(len(samples)) < 4)
    groups = groups_for_model(samples, config)
    ran: set[Path] = set()

    def record(frame: FrameType, event: str, arg: object) -> None:
        if event == "call":
            ran.add(Path(frame.f_code.co_filename).resolve())

    sys.setprofile(record)
    try:
        model = build_model(config)
        load_weights(model, stored.state_dict(), "test")
        for ablate in ((), ("edges",), ("scene",)):
            score_samples(model, config, samples, MODES_ALL, groups=groups, ablate=ablate)
        score_samples(
            model, config, samples, MODES_ALL, groups=groups, regions=RegionScoring((0.9,))
        )
    finally:
        sys.setprofile(None)
    package = Path(grouptron.__file__).resolve().parent
    ran_here = {path for path in ran if path.is_relative_to(package)}
    covered = scoring_sources(score_cache._model_modules(model))
    assert {"cvae.py", "stgcn.py", "predict.py", "factory.py"} <= {p.name for p in ran_here}
    assert ran_here <= covered, sorted(str(p) for p in ran_here - covered)
    assert not {"report.py", "app.py", "forecasts.py"} & {p.name for p in covered}


def test_a_report_run_again_reads_every_score_from_the_cache(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    path = tiny_checkpoints / "grouptron-eth-central/best.safetensors"
    entry = ReportCheckpoint("grouptron", "eth", "central", path)
    settings = ReportSettings(
        modes=("ml", "nll"), nll_max_samples=5, diagnostics=True, score_cache=tmp_path
    )
    first = score_checkpoint(entry, synthetic_data_dir, settings)
    calls = _count_scored(monkeypatch)
    again = score_checkpoint(entry, synthetic_data_dir, settings)
    assert calls == []
    assert again.rows == first.rows
    np.testing.assert_array_equal(again.ablated["scene"].fde, first.ablated["scene"].fde)


def _miss_rate(threshold_m: float):
    """A user's metric with a parameter in its closure: 1 where the final error exceeds it."""

    def miss(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
        return (metrics.fde(pred, truth) > threshold_m).astype(np.float64)

    return miss


def test_a_metric_registered_again_with_another_definition_is_scored_again(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    (plain,) = score_samples(model, config, samples, ("ml",))
    cut_m = float(np.median(plain.fde))  # half the samples on either side
    monkeypatch.setitem(
        metrics.METRICS, "miss", metrics.Metric("miss", "miss", _miss_rate(2 * cut_m))
    )
    (first,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    (again,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    assert len(calls) == 1  # read back while the definition is the same
    np.testing.assert_array_equal(first.get("miss"), again.get("miss"))
    for definition in (_miss_rate(cut_m), partial(_threshold_miss, threshold_m=cut_m / 2)):
        monkeypatch.setitem(metrics.METRICS, "miss", metrics.Metric("miss", "miss", definition))
        (changed,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
        expected = plain.fde > getattr(definition, "keywords", {}).get("threshold_m", cut_m)
        np.testing.assert_array_equal(changed.get("miss"), expected.astype(np.float64))
        assert not np.array_equal(changed.get("miss"), first.get("miss"))
    assert len(calls) == 3
    global _LIMIT_M
    _LIMIT_M = 0.0  # a global it reads changes: scored again too
    monkeypatch.setitem(metrics.METRICS, "miss", metrics.Metric("miss", "miss", _global_miss))
    (before,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    _LIMIT_M = 1e9
    (after,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    assert before.get("miss").all() and not after.get("miss").any()
    assert len(calls) == 5


_LIMIT_M = 0.0


def _threshold_miss(pred: np.ndarray, truth: np.ndarray, threshold_m: float) -> np.ndarray:
    return (metrics.fde(pred, truth) > threshold_m).astype(np.float64)


def _global_miss(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return (metrics.fde(pred, truth) > _LIMIT_M).astype(np.float64)
