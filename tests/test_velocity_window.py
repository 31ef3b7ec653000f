"""The windowed constant-velocity forecast of ``benchmarks/velocity_window.py``."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable
from types import ModuleType

import numpy as np

from grouptron.baselines.constant_velocity import constant_velocity
from tests.conftest import REPO


def _script() -> ModuleType:
    path = REPO / "benchmarks" / "velocity_window.py"
    spec = importlib.util.spec_from_file_location("velocity_window", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["velocity_window"] = module  # dataclasses look their module up
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop("velocity_window", None)
    return module


def _forecast() -> Callable[..., np.ndarray]:
    forecast: Callable[..., np.ndarray] = _script().windowed_velocity_forecast
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


def test_motion_counts_repeated_positions_and_turns_of_moving_samples_only() -> None:
    hist = np.zeros((4, 8, 2))
    mask = np.ones((4, 8), dtype=bool)
    # 0: still (t-2 = t-1 = t); 1: stop-go (still, then 0.4 m at the last step);
    # 2 and 3: 0.4 m steps that turn 90 and 0 degrees.
    hist[1, -3:-1] = [-0.4, 0.0]
    hist[2, -3:] = [[-0.4, -0.4], [0.0, -0.4], [0.0, 0.0]]
    hist[3, -3:] = [[-0.8, 0.0], [-0.4, 0.0], [0.0, 0.0]]
    seen = _script().motion(hist, mask)
    assert seen.still == 0.25 and seen.stop_go == 0.25
    assert seen.turn_deg == 45.0  # median of 90 and 0; the still and stop-go samples left out
    np.testing.assert_allclose(seen.speed_m_s, 1.0)  # median of 0, 1, 1, 1 m/s
