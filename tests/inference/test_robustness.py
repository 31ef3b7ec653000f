"""Forecasts stay finite and correct at the edges: standing still, 10 m/s, people on top of
each other, geo-referenced coordinates (shipped checkpoints, so real weights)."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron import Predictor
from grouptron.inference.forecast import Forecast
from grouptron.presets import DETECTION_GROUPS
from tests.helpers.data import walking_tracks

MODELS = [
    "grouptron-univ-backward",
    "trajectron++-univ-backward",
    "grouptron-robust-univ-backward",
    "trajectron++-residual-univ-backward",
    "grouptron-robust-residual-univ-backward",
    "grouptron-robust-residual-crowds-backward",  # the default model
]


@pytest.fixture(scope="module", params=MODELS)
def predictor(request: pytest.FixtureRequest) -> Predictor:
    return Predictor.from_checkpoint(request.param, forecast="ml", mixture=True)


def _scene(kind: str) -> np.ndarray:
    """(R, 4) rows of 6 people over 12 steps."""
    if kind == "standing still":
        return walking_tracks(6, 12, seed=3, speed=0.0, offset=0.0)
    if kind == "10 m/s":
        return walking_tracks(6, 12, seed=3, speed=10.0, offset=0.0)
    if kind == "coincident":  # everyone at the same point at every step, walking together
        rows = walking_tracks(6, 12, seed=3, speed=1.3, offset=0.0)
        leader = rows[rows[:, 1] == 0]
        rows[:, 2:] = np.tile(leader[:, 2:], (6, 1))
        return rows
    raise ValueError(kind)


def _assert_finite(forecast: Forecast) -> None:
    assert forecast.mixture is not None, "mixture"
    for name, value in (
        ("point", forecast.point),
        ("samples", forecast.samples),
        ("mixture.means", forecast.mixture.means),
        ("mixture.covariances", forecast.mixture.covariances),
    ):
        assert value is not None and np.isfinite(value).all(), name


@pytest.mark.parametrize("kind", ["standing still", "10 m/s", "coincident"])
def test_forecasts_are_finite_at_the_edges(predictor: Predictor, kind: str) -> None:
    rows = _scene(kind)
    predictor.check_speed = kind != "10 m/s"  # runners: past the pedestrian plausibility check
    forecast = predictor.predict(rows, num_samples=5)
    assert len(forecast) == 6
    _assert_finite(forecast)
    if kind == "standing still":  # a model that learned anything keeps still people near
        assert np.abs(forecast.point[:, -1] - rows[rows[:, 0] == 110][:, 2:]).max() < 2.0
    if kind == "coincident":  # identical people, identical forecasts
        np.testing.assert_allclose(forecast.point, forecast.point[:1].repeat(6, 0))
        # C(6) = 3 groups by the paper's rule; a distance threshold merges people 0 m apart.
        by_threshold = predictor.group_rule.max_distance_m is not None
        assert len(np.unique(forecast.group)) == (1 if by_threshold else 3)


@pytest.mark.parametrize("offset", [1e5, -3e6])
def test_geo_referenced_coordinates_shift_the_forecast_exactly(
    predictor: Predictor, offset: float
) -> None:
    rows = walking_tracks(6, 12, seed=5, speed=1.3, offset=0.0)
    shifted = rows.copy()
    shifted[:, 2:] += offset
    near, far = predictor.predict(rows, num_samples=3), predictor.predict(shifted, num_samples=3)
    _assert_finite(far)
    np.testing.assert_allclose(far.point - offset, near.point, atol=1e-3)
    np.testing.assert_allclose(far.samples - offset, near.samples, atol=1e-3)
    np.testing.assert_array_equal(far.group, near.group)


def test_groups_follow_the_model_or_the_detection_rule(predictor: Predictor) -> None:
    """A model that reads groups is shown its own groups; any other, the rule chosen on human
    labels (``grouptron groups detect --detector distance``'s)."""
    reads_groups = predictor.config.model_name.startswith("grouptron")
    expected = predictor.config.groups if reads_groups else DETECTION_GROUPS
    assert predictor.group_rule == expected
    # Four people walking abreast 0.6 m apart and one alone 30 m away: a 1.5 m threshold finds
    # the four and the one (2 groups), the paper's C(5) = 3 groups must split the four.
    steps = np.arange(12)
    rows = [
        np.column_stack([steps * 10, np.full(12, i), steps * 0.5, np.full(12, y)])
        for i, y in enumerate([0.0, 0.6, 1.2, 1.8, 30.0])
    ]
    forecast = predictor.predict(np.concatenate(rows))
    found = len(np.unique(forecast.group))
    by_threshold = predictor.group_rule.max_distance_m is not None
    assert found == (2 if by_threshold else 3)
