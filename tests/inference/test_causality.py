"""Strictly causal backward derivatives: what happens after t never changes a forecast at t."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from grouptron.data.datasets.locate import split_files
from grouptron.inference.predictor import Predictor


def _forecasts_at(predictor: Predictor, rows: np.ndarray, frames: list[int]) -> None:
    forecasts = 0
    for frame in frames:
        whole = predictor.predict(rows, frame, live=False)
        cut = predictor.predict(rows[rows[:, 0] <= frame], frame, live=False)
        np.testing.assert_array_equal(whole.ids, cut.ids)
        np.testing.assert_allclose(whole.point, cut.point, atol=1e-6)
        forecasts += len(whole)
    assert forecasts >= len(frames)


@pytest.mark.realdata
@pytest.mark.parametrize("model", ["grouptron", "trajectron++", "default"])
def test_cutting_a_real_recording_after_t_never_changes_a_forecast_made_at_t(
    tiny_checkpoints: Path, eth_ucy_dir: Path, model: str
) -> None:
    """Both models and the default one, trained strictly causal (the shipped Trajectron++ univ
    checkpoint, a tiny Grouptron and the default model with its own forecast), forecasting
    everyone with 2 or more points, missed steps filled."""
    if model == "grouptron":
        predictor = Predictor.from_checkpoint(
            tiny_checkpoints / "grouptron-eth-backward", forecast="ml"
        )
    elif model == "trajectron++":
        predictor = Predictor.from_checkpoint("trajectron++-univ-backward", forecast="ml")
    else:
        predictor = Predictor.from_checkpoint()
    if model != "default":
        assert predictor.config.model_name == model
    rows = np.loadtxt(split_files(eth_ucy_dir, "eth", "test")[0])
    frames = np.unique(rows[:, 0]).astype(int)
    busy = [int(f) for f in frames[200:1000:80]]  # spread over the recording
    assert predictor.config.data.backward_start == "zero"
    _forecasts_at(predictor, rows, busy)


@pytest.mark.realdata
def test_the_reference_backward_start_reads_the_future(
    tiny_checkpoints: Path, eth_ucy_dir: Path
) -> None:
    """The check above can fail: with the reference's start (v[0] = v[1]) a person first seen
    at t gets a velocity from t + 1, and forecasts at t change when the recording is cut."""
    predictor = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    data = dataclasses.replace(predictor.config.data, backward_start="next")
    predictor.config = dataclasses.replace(predictor.config, data=data)
    rows = np.loadtxt(split_files(eth_ucy_dir, "eth", "test")[0])
    first_seen = {int(p): rows[rows[:, 1] == p, 0].min() for p in np.unique(rows[:, 1])}
    frames = sorted({int(f) for f in first_seen.values()})[20:60]  # someone appears at each
    with pytest.raises(AssertionError):
        _forecasts_at(predictor, rows, frames)
