"""A live session at the tracker's own rate: times in seconds, any hashable ids, the history
resampled causally onto the step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.errors import GrouptronError, LateUpdateError
from grouptron.inference.live import LiveTracks
from grouptron.inference.predictor import Predictor
from tests.golden.compute import synthetic_tracks


def _at_30_fps() -> tuple[np.ndarray, np.ndarray]:
    """The golden scene's people at 30 fps ((R,) seconds, (R, 3) id, x, y): each 0.4 s row
    interpolated to 12 frames, so that every 12th frame is the scene's own row."""
    scene = synthetic_tracks()  # frame (10 per 0.4 s), id, x, y
    times, rows = [], []
    for person in np.unique(scene[:, 1]):
        own = scene[scene[:, 1] == person]
        seconds = own[:, 0] / 25.0
        fine = np.arange(seconds[0], seconds[-1] + 1e-9, 1 / 30)
        x, y = np.interp(fine, seconds, own[:, 2]), np.interp(fine, seconds, own[:, 3])
        times.append(np.round(fine * 30) / 30)
        rows.append(np.column_stack([np.full(len(fine), person), x, y]))
    return np.concatenate(times), np.concatenate(rows)


def test_seconds_at_30_fps_forecast_as_frames_on_the_grid() -> None:
    """At times on the 0.4 s grid the resampled history is the scene's own rows, so the
    forecasts equal those of a frame-numbered session fed the scene itself."""
    predictor = Predictor.from_checkpoint(calibration=False)
    times, rows = _at_30_fps()
    live, framed = predictor.stream(), predictor.stream()
    scene = synthetic_tracks()
    by_frame = {int(f): scene[scene[:, 0] == f] for f in np.unique(scene[:, 0])}
    compared = 0
    for t in np.unique(times):
        now = rows[times == t]
        names = [f"person-{int(i)}" for i in now[:, 0]]
        forecast = live.update(float(t), names, now[:, 1:3])
        frame = round(t * 25)
        if frame % 10 or frame not in by_frame:
            continue
        expected = framed.update(frame, by_frame[frame][:, 1], by_frame[frame][:, 2:4])
        if not len(expected):
            continue
        assert list(forecast.ids) == [f"person-{int(i)}" for i in expected.ids]  # names kept
        np.testing.assert_allclose(forecast.point, expected.point, atol=1e-4)
        assert forecast.time_s == pytest.approx(t) and forecast.frame is None
        compared += 1
    assert compared >= 8


def test_a_jittered_tracker_with_dropped_messages_is_answered_at_every_update() -> None:
    rng = np.random.default_rng(0)
    session = Predictor.from_checkpoint().stream(online_calibration=True)
    start = 1_700_000_000.0
    times = np.sort(start + np.arange(0, 15, 0.1) + rng.uniform(-0.03, 0.03, 150))
    times = times[rng.uniform(size=len(times)) > 0.15]  # dropped messages
    answered = 0
    for t in times:
        ids = ["a", "b", ("robot", 3)]  # any hashable names
        xy = np.array([[t - start, 0.0], [0.0, 1.3 * (t - start)], [5.0, 5.0]])
        forecast = session.update(float(t), ids, xy)
        answered += len(forecast) > 0
    assert answered > len(times) - 40  # from about 3 s on, every update is answered
    assert set(forecast.ids) == {"a", "b", ("robot", 3)}
    assert session.online is not None and session.online.scored[0] > 50
    assert np.isfinite(forecast.regions(0.9).major_m).all()


def test_late_updates_or_frames_mixed_with_seconds_are_refused() -> None:
    session = Predictor.from_checkpoint().stream()
    session.update(10.0, [1], [[0.0, 0.0]])
    with pytest.raises(LateUpdateError, match="not after the previous update"):
        session.update(9.9, [1], [[0.0, 0.0]])
    assert session.faults.late == 1
    with pytest.raises(GrouptronError, match="fed times in seconds"):
        session.update(20, [1], [[0.0, 0.0]])
    with pytest.raises(GrouptronError, match=r"positions must be \(N, 2\)"):
        session.update(10.5, [1, 2], [[0.0, 0.0]])


def test_resampling_is_causal_and_leaves_gaps_empty() -> None:
    tracks = LiveTracks(window_s=5.0, max_gap_s=0.8)
    tracks.add(0.0, np.array([7]), np.array([[0.0, 0.0]]))
    tracks.add(0.3, np.array([7]), np.array([[0.3, 0.0]]))
    tracks.add(2.0, np.array([7]), np.array([[2.0, 0.0]]))  # after a 1.7 s gap
    xy, found = tracks.positions_at(np.array([7, 7, 7]), np.array([0.1, 1.0, 2.0]))
    np.testing.assert_allclose(xy[0], [0.1, 0.0])
    assert found.tolist() == [True, False, True]  # the gap is not bridged


def test_frame_numbers_with_string_names_keep_the_names(tmp_path: Path) -> None:
    session = Predictor.from_checkpoint().stream()
    scene = synthetic_tracks()
    for frame in np.unique(scene[:, 0]):
        now = scene[scene[:, 0] == frame]
        forecast = session.update(int(frame), [f"p{int(i)}" for i in now[:, 1]], now[:, 2:4])
    assert all(isinstance(i, str) and i.startswith("p") for i in forecast.ids)


def test_people_given_from_a_moving_robot_with_its_pose_forecast_as_in_the_fixed_frame() -> None:
    from grouptron.geometry import rotation_matrix

    predictor = Predictor.from_checkpoint()
    robot, fixed = predictor.stream(), predictor.stream()
    for k in range(12):
        t = 1_700_000_000.0 + 0.4 * k
        pose = np.array([0.4 * k, 0.1 * k, 0.15 * k])  # driving and turning
        xy = np.array([[1.2 * 0.4 * k, 3.0], [5.0, 5.0]])  # a walker, someone standing
        in_robot = (xy - pose[:2]) @ rotation_matrix(np.asarray(pose[2]))
        seen = robot.update(t, ["w", "s"], in_robot, pose=pose)
        expected = fixed.update(t, ["w", "s"], xy)
    np.testing.assert_allclose(seen.point, expected.point, atol=1e-6)
    with pytest.raises(GrouptronError, match="pose must be"):
        robot.update(t + 0.4, ["w"], [[0.0, 0.0]], pose=[0.0, np.nan, 0.0])
