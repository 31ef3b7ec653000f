"""The windowed constant-velocity forecast of ``benchmarks/velocity_window.py``."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

import numpy as np

from grouptron.baselines.constant_velocity import constant_velocity
from tests.conftest import REPO


def _forecast() -> Callable[..., np.ndarray]:
    path = REPO / "benchmarks" / "velocity_window.py"
    spec = importlib.util.spec_from_file_location("velocity_window", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    forecast: Callable[..., np.ndarray] = module.windowed_velocity_forecast
    return forecast


def test_a_window_of_one_step_is_the_baseline_and_longer_ones_average() -> None:
    forecast = _forecast()
    rng = np.random.default_rng(0)
    hist = np.cumsum(rng.normal(size=(5, 8, 2)), axis=1)
    hist -= hist[:, -1:]  # relative to the current position
    mask = np.ones((5, 8), dtype=bool)
    np.testing.assert_allclose(forecast(hist, mask, 12, 1), constant_velocity(hist, 12))
    # Three steps back: the mean displacement of the last three steps, repeated.
    three = forecast(hist, mask, 12, 3)
    np.testing.assert_allclose(three[:, 0], -hist[:, -4] / 3)
    np.testing.assert_allclose(three[:, 11], 12 * three[:, 0])


def test_the_window_shrinks_to_the_observed_steps() -> None:
    forecast = _forecast()
    hist = np.zeros((2, 8, 2))
    hist[0, -2:] = [[-1.0, 0.0], [0.0, 0.0]]  # observed at t-1 and t only, 1 m per step
    mask = np.zeros((2, 8), dtype=bool)
    mask[0, -2:] = True
    mask[1, -1] = True  # only the current position: taken to stand still
    out = forecast(hist, mask, 3, 4)
    np.testing.assert_allclose(out[0], [[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    np.testing.assert_allclose(out[1], 0.0)
