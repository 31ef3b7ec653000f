"""Everyone in view gets a forecast: short histories and missed detections in a live stream."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron import Predictor


def tracker_stream(
    people: int, steps: int, missed: float, seed: int = 0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(ids, (N, 2) positions) per step of a crowd crossing a square at 0.8-1.6 m/s; a person
    leaving is replaced by a newcomer with a new id, and a fraction ``missed`` of detections
    is dropped at random."""
    rng = np.random.default_rng(seed)
    side = 2.0 * np.sqrt(people)

    def velocities(n: int) -> np.ndarray:
        heading = rng.uniform(0, 2 * np.pi, n)
        return rng.uniform(0.8, 1.6, (n, 1)) * np.stack([np.cos(heading), np.sin(heading)], 1)

    pos, vel, ids = rng.uniform(0, side, (people, 2)), velocities(people), np.arange(people)
    frames = []
    for _ in range(steps):
        seen = rng.random(people) >= missed
        frames.append((ids[seen].copy(), pos[seen].copy()))
        pos = pos + 0.4 * vel
        gone = ((pos < 0) | (pos > side)).any(axis=1)
        pos[gone], vel[gone] = rng.uniform(0, side, (int(gone.sum()), 2)), velocities(gone.sum())
        ids[gone] = ids.max() + 1 + np.arange(int(gone.sum()))
    return frames


def coverage(predictor: Predictor, frames: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Worst fraction, over the steps, of the people in view seen before (2 or more points)
    who get a forecast."""
    session, seen_before, worst = predictor.stream(), set(), 1.0
    for step, (ids, xy) in enumerate(frames):
        forecast = session.update(10 * step, ids, xy)
        eligible = {int(i) for i in ids} & seen_before
        if eligible:
            got = eligible & {int(i) for i in forecast.ids}
            worst = min(worst, len(got) / len(eligible))
        seen_before |= {int(i) for i in ids}
    return worst


@pytest.fixture(scope="module")
def stream() -> list[tuple[np.ndarray, np.ndarray]]:
    return tracker_stream(people=30, steps=40, missed=0.03)


def test_everyone_seen_twice_gets_a_forecast_despite_missed_detections(
    tiny_checkpoints: Path, stream: list[tuple[np.ndarray, np.ndarray]]
) -> None:
    predictor = Predictor.from_checkpoint(
        "grouptron-eth-backward", checkpoints_dir=tiny_checkpoints, mixture=False
    )
    assert coverage(predictor, stream) >= 0.99


def test_without_filling_or_short_histories_coverage_falls(
    tiny_checkpoints: Path, stream: list[tuple[np.ndarray, np.ndarray]]
) -> None:
    """The check above can fail: restarting tracks at every miss loses people."""
    path = tiny_checkpoints / "grouptron-eth-backward"
    no_fill = Predictor.from_checkpoint(path, mixture=False, max_missed_steps=0)
    assert coverage(no_fill, stream) < 0.99
    full_history = Predictor.from_checkpoint(path, mixture=False, min_points=8)
    assert coverage(full_history, stream) < 0.5


def test_forecasts_say_how_many_points_they_used(tiny_checkpoints: Path) -> None:
    predictor = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    rows = [[0, 1, 0.0, 0.0], [10, 1, 0.5, 0.0], [20, 1, 1.0, 0.0], [40, 1, 2.0, 0.0]]  # 30 missed
    rows += [[30, 2, 3.0, 3.0], [40, 2, 3.5, 3.0], [40, 3, 9.0, 9.0]]  # 3 is seen only once
    forecast = predictor.predict(np.asarray(rows), t=40)
    np.testing.assert_array_equal(forecast.ids, [1, 2])
    np.testing.assert_array_equal(forecast.observed_points, [4, 2])
    np.testing.assert_array_equal(forecast.filled_points, [1, 0])
    assert np.isfinite(forecast.point).all()


def test_minimum_points_and_gap_settings_are_checked(tiny_checkpoints: Path) -> None:
    from grouptron.errors import GrouptronError

    path = tiny_checkpoints / "grouptron-eth-backward"
    for bad in ({"min_points": 1}, {"min_points": 9}, {"max_missed_steps": -1}):
        with pytest.raises(GrouptronError, match=next(iter(bad))):
            Predictor.from_checkpoint(path, **bad)
