"""``evaluate --regions``: a point forecast's prediction regions scored as metrics (coverage and
area per step) on track files, in the table, the JSON, by density and from Python, the same
regions the forecasting engine draws; ``--calibration`` sizes them with a calibration file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.engine import forecast_samples
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import prediction_regions
from grouptron.workflows.evaluate import EvaluationOptions, Tracks, evaluate
from tests.conftest import synthetic_recording

H = 12


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recording of 14 people over 24 s: a few hundred forecasts with a full future."""
    path = tmp_path_factory.mktemp("regions") / "site.txt"
    return synthetic_recording(path, seed=11, pedestrians=14, steps=60)


@pytest.fixture(scope="module")
def checkpoint(tiny_checkpoints: Path) -> Path:
    return tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> list[dict[str, object]]:
    capsys.readouterr()
    assert main([*argv, "--format", "json", "--quiet"]) == 0
    rows: list[dict[str, object]] = json.loads(capsys.readouterr().out)["results"]
    return rows


def _pooled(rows: list[dict[str, object]], model: str = "grouptron") -> list[dict[str, object]]:
    return [r for r in rows if r["split"] == "all files" and r["model"] == model]


def test_regions_are_scored_per_step_in_the_json_and_the_table(
    checkpoint: Path, site: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--checkpoint", str(checkpoint), "--tracks", str(site)]
    argv += ["--mode", "ml-argmax,ml", "--regions", "0.5,0.9"]
    rows = _json(capsys, argv)
    for row in _pooled(rows):  # one per mode
        for q in ("50", "90"):
            steps = np.array(row[f"coverage-q{q}_per_step"], dtype=float)
            assert steps.shape == (H,) and np.all((steps >= 0) & (steps <= 1))
            assert row[f"coverage-q{q}"] == pytest.approx(steps.mean())
            assert row[f"area-q{q}"] == pytest.approx(np.mean(row[f"area-q{q}_per_step"]))
        assert np.all(np.array(row["area-q90_per_step"]) > np.array(row["area-q50_per_step"]))
        assert np.all(np.array(row["coverage-q90_per_step"]) >= row["coverage-q50_per_step"])
        assert row["area-q90_per_step"][-1] > row["area-q90_per_step"][0]  # wider far ahead
    (baseline,) = _pooled(rows, "constant-velocity")
    assert baseline["coverage-q90"] is None and baseline["area-q90_per_step"] is None

    capsys.readouterr()
    assert main([*argv, "--quiet"]) == 0
    header, _, *lines = capsys.readouterr().out.splitlines()
    for heading in ("cov90 @4", "cov90 @8", "cov90 @12", "cov90", "area50 m2 @4", "area90 m2"):
        assert heading in header
    pooled = next(line for line in lines if line.startswith("all files") and "(ml)" in line)
    (ml,) = [r for r in _pooled(rows) if r["mode"] == "ml"]
    assert f"{ml['coverage-q90_per_step'][7]:.3f}" in pooled  # step 8's column


def test_coverage_by_density_bin_adds_up_to_the_pooled_coverage(
    checkpoint: Path, site: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--checkpoint", str(checkpoint), "--tracks", str(site)]
    rows = _pooled(_json(capsys, [*argv, "--regions", "0.9", "--by-density"]))
    whole = next(r for r in rows if r["subset"] is None)
    bins = [r for r in rows if r["subset"] is not None]
    assert len(bins) >= 2 and sum(r["samples"] for r in bins) == whole["samples"]
    for name in ("coverage-q90", "area-q90"):
        weighted = sum(r[name] * r["samples"] for r in bins) / whole["samples"]
        assert weighted == pytest.approx(whole[name])
        assert all(len(r[f"{name}_per_step"]) == H for r in bins)


def test_evaluate_scores_the_regions_the_engine_draws(checkpoint: Path, site: Path) -> None:
    rows = evaluate(Tracks((site,)), checkpoint, options=EvaluationOptions(regions=(0.9,)))
    (row,) = [r for r in rows if r.split == "all files" and r.model == "grouptron"]
    model, config = load_trained_model(checkpoint)
    samples = recording_samples(Tracks((site,)).sources, config.data)
    forecast = default_point_forecast(config)
    made = forecast_samples(model, config, samples, forecast, groups_for_model(samples, config))
    assert made.distribution is not None and row.mode == forecast.name
    regions = prediction_regions(made.point, made.distribution, 0.9)
    inside = regions.contains(samples.fut_rel_m.astype(np.float64))  # (S, H)
    assert row.samples == len(inside)
    assert row.per_step["coverage-q90"] == pytest.approx(inside.mean(axis=0), abs=1e-9)
    area = np.pi * regions.major_m * regions.minor_m
    assert row.per_step["area-q90"] == pytest.approx(area.mean(axis=0), rel=1e-4)
    assert row.metrics_ci["coverage-q90"][0] <= row.metrics["coverage-q90"]


def test_a_calibration_sizes_the_regions_to_hold_q_on_its_own_recording(
    checkpoint: Path, site: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    calibration = tmp_path / "site.json"
    calibrate = ["calibrate", "--checkpoint", str(checkpoint), "--tracks", str(site)]
    assert main([*calibrate, "--out", str(calibration)]) == 0
    argv = ["evaluate", "--checkpoint", str(checkpoint), "--tracks", str(site), "--regions", "0.9"]
    (own,) = _pooled(_json(capsys, argv))
    (calibrated,) = _pooled(_json(capsys, [*argv, "--calibration", str(calibration)]))
    assert own["area-q90_per_step"] != pytest.approx(calibrated["area-q90_per_step"])
    # In-sample, the conformal radius of each step holds at least ceil((n + 1) q) of the n
    # scores (one may sit on the boundary, within rounding).
    n = calibrated["samples"]
    assert all(c >= 0.9 - 1.0 / n for c in calibrated["coverage-q90_per_step"])
    with pytest.raises(GrouptronError, match="calibrated for"):
        options = EvaluationOptions(regions=(0.9,), calibration=calibration)
        evaluate(Tracks((site,)), checkpoint, ("ml",), options)
