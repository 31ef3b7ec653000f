"""Prediction regions as metrics: coverage (a share in [0, 1]) and area (m^2) per step, of the
model's own regions or calibrated ones, in rows, tables and JSON."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import SampleScores
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.evaluation.results import (
    EvaluationResult,
    mean_over_splits,
    results_json,
    results_table,
    score_rows,
)
from grouptron.model.mixture import Mixture
from grouptron.model.regions import Regions

H = 12


def _gaussian(count: int, sigma_m: np.ndarray) -> tuple[np.ndarray, Mixture]:
    """(N, H, 2) forecasts at the origin and one Gaussian per person centred on them, of
    (H,) standard deviations ``sigma_m`` along x and half of them along y."""
    covariance = np.zeros((count, 1, H, 2, 2))
    covariance[..., 0, 0] = sigma_m**2
    covariance[..., 1, 1] = (sigma_m / 2) ** 2
    mixture = Mixture(np.zeros((count, 1)), np.zeros((count, 1, H, 2)), covariance)
    return np.zeros((count, H, 2)), mixture


def test_coverage_and_area_of_a_known_ellipse() -> None:
    centre = np.zeros((1, 2, 2))
    regions = Regions(0.9, centre, np.full((1, 2), 2.0), np.full((1, 2), 1.0), np.zeros((1, 2)))
    truth = np.array([[[1.9, 0.0], [0.0, 1.1]]])  # inside along x, outside across
    scores = metrics.region_scores(regions, truth)
    assert set(scores) == {"coverage-q90", "area-q90"}
    np.testing.assert_array_equal(scores["coverage-q90"], [[1.0, 0.0]])
    np.testing.assert_allclose(scores["area-q90"], [[2 * math.pi, 2 * math.pi]])


def test_a_gaussian_s_own_regions_hold_q_and_grow_with_q() -> None:
    sigma = np.linspace(0.1, 1.2, H)
    point, mixture = _gaussian(4000, sigma)
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(4000, H, 2)) * np.stack([sigma, sigma / 2], -1)
    scores = RegionScoring((0.5, 0.9)).scores(point, mixture, truth)
    for q in (0.5, 0.9):
        coverage = scores[f"coverage-q{q * 100:g}"].mean(axis=0)  # (H,)
        assert np.all(np.abs(coverage - q) < 0.03), coverage
        chi_square = -2.0 * math.log(1.0 - q)  # the ellipse of one centred Gaussian
        area = math.pi * chi_square * sigma * (sigma / 2)
        np.testing.assert_allclose(scores[f"area-q{q * 100:g}"][0], area, rtol=0.02)
    assert np.all(scores["area-q90"] > scores["area-q50"])


def test_calibrated_radii_size_the_regions() -> None:
    sigma = np.full(H, 0.5)
    point, mixture = _gaussian(3, sigma)
    radius = np.linspace(1.0, 3.0, H)
    scoring = RegionScoring((0.9,), {0.9: radius})
    scores = scoring.scores(point, mixture, np.zeros((3, H, 2)))
    np.testing.assert_allclose(scores["area-q90"][0], math.pi * radius**2 * 0.5 * 0.25)
    assert scoring.calibrated and scoring.key() != RegionScoring((0.9,)).key()
    assert RegionScoring((0.9,)).key() != RegionScoring((0.5,)).key()


@pytest.mark.parametrize(
    ("qs", "radii", "message"),
    [
        ((0.0,), {}, "must be in"),
        ((1.0,), {}, "must be in"),
        ((), {}, "must be in"),
        ((0.5, 0.9), {0.9: np.ones(H)}, "lack q"),
    ],
)
def test_region_scoring_refuses_what_has_no_region(
    qs: tuple[float, ...], radii: dict[float, np.ndarray], message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        RegionScoring(qs, radii)


def test_region_metric_names_and_labels() -> None:
    assert metrics.region_metric_names((0.5, 0.975)) == (
        "coverage-q50",
        "area-q50",
        "coverage-q97.5",
        "area-q97.5",
    )
    assert metrics.metric_label("coverage-q90") == "cov90"
    assert metrics.metric_label("area-q97.5") == "area97.5 m2"
    assert metrics.metric_label("fde") == "FDE m"


def _scores(mode: str, coverage: np.ndarray, area: np.ndarray) -> SampleScores:
    """Scores of S samples with (S, H) region metrics at q = 0.9."""
    per_step = {"coverage-q90": coverage, "area-q90": area}
    values = {"ade": np.ones(len(area)), "fde": np.ones(len(area))}
    values.update({k: v.mean(axis=1) for k, v in per_step.items()})
    return SampleScores(mode, values, per_step)


def test_rows_tables_and_json_carry_every_step_and_constant_velocity_shows_null() -> None:
    rng = np.random.default_rng(1)
    coverage = (rng.random((10, H)) < 0.8).astype(float)
    area = rng.random((10, H)) * np.arange(1, H + 1)
    dense = np.arange(10) >= 6
    template = EvaluationResult("site", "grouptron", None, 0, 0.0, 0.0)
    rows = score_rows(template, _scores("ml", coverage, area), {None: None, "6-9": dense})
    whole, bin_ = rows
    assert whole.per_step["coverage-q90"] == pytest.approx(coverage.mean(axis=0))
    assert bin_.per_step["area-q90"] == pytest.approx(area[dense].mean(axis=0))
    assert whole.metrics["coverage-q90"] == pytest.approx(coverage.mean())
    baseline = EvaluationResult("site", "constant-velocity", None, 10, 1.0, 1.0)
    table = results_table([*rows, baseline])
    header, _, model_line, _, cv_line = table.splitlines()
    for heading in ("cov90 @4", "cov90 @8", "cov90 @12", "cov90", "area90 m2 @12", "area90 m2"):
        assert heading in header
    assert f"{coverage[:, 3].mean():.3f}" in model_line  # step 4's column
    assert cv_line.split()[-1] == "-"  # no distribution, no region
    parsed = json.loads(results_json([*rows, baseline]))["results"]
    assert parsed[0]["coverage-q90_per_step"] == pytest.approx(list(coverage.mean(axis=0)))
    assert len(parsed[1]["area-q90_per_step"]) == H
    assert parsed[2]["coverage-q90"] is None and parsed[2]["area-q90_per_step"] is None


def test_the_mean_over_splits_averages_every_metric() -> None:
    rows = [
        EvaluationResult(
            split,
            "grouptron",
            None,
            5,
            1.0,
            2.0,
            metrics={"coverage-q90": value},
            per_step={"coverage-q90": (value,) * H},
        )
        for split, value in (("eth", 0.5), ("hotel", 0.9))
    ]
    mean = mean_over_splits(rows)
    assert mean.metrics["coverage-q90"] == pytest.approx(0.7)
    assert mean.per_step["coverage-q90"] == pytest.approx((0.7,) * H)
