"""Calibrations that say what they can promise: whole-path radii, too few forecasts refused
alike at every q, a site unlike the calibration's named, plots that say whether their regions
are calibrated."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import (
    MIN_FORECASTS,
    calibration_from_scores,
    condition_mismatch,
    load_calibration,
)


def test_whole_path_radii_hold_whole_paths_where_per_step_ones_do_not() -> None:
    rng = np.random.default_rng(0)
    calibrate_on, check_on = (
        rng.rayleigh(1.0 + 0.2 * np.arange(12), size=(n, 12)) for n in (4000, 4000)
    )
    calibration = calibration_from_scores(calibrate_on, np.zeros((4000, 12), dtype=bool))
    step = calibration.radius(0.9)
    path = calibration.radius(0.9, joint=True)
    assert (path > step).all()  # each step's ellipse is wider, so that all of them hold
    whole = (check_on <= path).all(axis=1).mean()
    assert whole == pytest.approx(0.9, abs=0.02)
    assert (check_on <= step).all(axis=1).mean() < 0.6  # per-step radii miss whole paths


def test_too_few_forecasts_support_no_q_and_say_how_many_each_needs() -> None:
    few = calibration_from_scores(np.ones((MIN_FORECASTS - 1, 12)), np.ones((19, 12), bool))
    for q in (0.5, 0.9):
        with pytest.raises(GrouptronError, match=f"from 19 forecasts cannot support q = {q:g}"):
            few.radius(q)
    enough = calibration_from_scores(np.ones((50, 12)), np.ones((50, 12), bool))
    assert np.isfinite(enough.radius(0.9)).all()
    with pytest.raises(GrouptronError, match="needs at least 99"):
        enough.radius(0.99)


def test_a_site_unlike_the_calibrations_is_named() -> None:
    calibration = calibration_from_scores(np.ones((50, 12)), np.ones((50, 12), bool))
    calibration = calibration.__class__(
        **{**calibration.__dict__, "density": 1.0, "speed_mps": 1.3}
    )
    assert condition_mismatch(calibration, 1.5, 1.2) == ""
    assert "here 6 and 1.2 m/s" in condition_mismatch(calibration, 6.0, 1.2)
    assert condition_mismatch(calibration, 1.0, 0.5) != ""


def test_calibrate_records_the_site_and_predict_draws_whole_path_regions(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    recording = split_files(synthetic_data_dir, "eth", "train")[0]
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    site = tmp_path / "site.json"
    assert main(["calibrate", "--checkpoint", checkpoint, "--tracks", str(recording),
                 "--out", str(site)]) == 0  # fmt: skip
    calibration = load_calibration(site)
    assert calibration.density >= 0 and calibration.speed_mps > 0.3
    assert calibration.joint_radii.shape == (99,) and calibration.joint_scale.shape == (12,)
    out = {kind: tmp_path / f"{kind}.csv" for kind in ("step", "path")}
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(recording), "--quiet",
            "--regions", "0.9", "--calibration", str(site)]  # fmt: skip
    assert main([*argv, "--out", str(out["step"])]) == 0
    assert main([*argv, "--out", str(out["path"]), "--joint"]) == 0
    step, path = (np.loadtxt(out[k], delimiter=",", skiprows=1) for k in ("step", "path"))
    wider = path[:, -3] - step[:, -3]  # semi-major axes: wider, so that the whole path holds
    assert (wider >= -1e-4).all() and (wider > 0).mean() > 0.5


def test_plots_say_whether_their_regions_are_calibrated(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    from grouptron.viz import forecasts

    labels = []
    original = forecasts._add_legend

    def spy(ax, panel):  # type: ignore[no-untyped-def]
        original(ax, panel)
        labels.extend(t.get_text() for t in ax.get_legend().get_texts())

    recording = split_files(synthetic_data_dir, "eth", "test")[0]
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    with pytest.MonkeyPatch.context() as patch, caplog.at_level(logging.WARNING):
        patch.setattr(forecasts, "_add_legend", spy)
        assert main(["plot", "--checkpoint", checkpoint, "--tracks", str(recording),
                     "--out", str(tmp_path / "p.png"), "--quiet"]) == 0  # fmt: skip
    assert any("region" in label and label.endswith("(uncalibrated)") for label in labels)
