"""A live session survives what trackers get wrong: clocks that jump, late messages, ids
reused for someone else (``inference.track_faults``), through ``Predictor.stream()``."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.errors import LateUpdateError
from grouptron.inference.predictor import Predictor
from grouptron.inference.track_faults import (
    JUMP_FORWARD_S,
    LATE_TOLERANCE_S,
    Clock,
    clock_step,
    unreachable,
)

START_S = 1_700_000_000.0


def test_clock_steps_by_name() -> None:
    assert clock_step(None, 5.0) is Clock.NEXT
    assert clock_step(10.0, 10.1) is Clock.NEXT
    assert clock_step(10.0, 10.0 + JUMP_FORWARD_S) is Clock.NEXT  # a tracker that paused
    assert clock_step(10.0, 10.1 + JUMP_FORWARD_S) is Clock.JUMPED_FORWARD
    assert clock_step(10.0, 10.0) is Clock.LATE  # the same stamp twice
    assert clock_step(10.0, 10.0 - LATE_TOLERANCE_S) is Clock.LATE
    assert clock_step(10.0, 9.9 - LATE_TOLERANCE_S) is Clock.JUMPED_BACK


def test_reappearances_no_walker_makes_by_name() -> None:
    """Hand-made cases: last seen at the origin walking +x at 1.3 m/s (or standing)."""
    walking, unknown = np.array([1.3, 0.0]), np.array([np.nan, np.nan])
    cases = {  # name: (gap s, velocity, position now, unreachable?)
        "walker_keeps_pace_0.5s": (0.5, walking, [0.65, 0.0], False),
        "walker_stops_0.5s": (0.5, walking, [0.3, 0.0], False),
        "runner_keeps_pace_0.5s": (0.5, np.array([5.0, 0.0]), [2.5, 0.0], False),
        "walker_turns_back_over_1.2s": (1.2, walking, [0.2, 0.5], False),
        "reused_id_4m_away_0.5s": (0.5, walking, [-4.0, 0.0], True),
        "reused_id_walking_back_fast_0.5s": (0.5, walking, [-1.0, 0.0], True),
        "standing_then_3m_away_0.6s": (0.6, np.zeros(2), [3.0, 0.0], True),
        "next_message_noise_0.1s": (0.1, walking, [0.9, 0.0], False),  # no gap: speed only
        "glitch_without_velocity": (0.1, unknown, [2.0, 0.0], True),  # 20 m/s
        "unknown_velocity_after_gap": (0.5, unknown, [3.0, 0.0], False),  # 6 m/s: can't tell
    }
    gap = np.array([c[0] for c in cases.values()])
    velocity = np.stack([c[1] for c in cases.values()])
    now = np.array([c[2] for c in cases.values()], dtype=np.float64)
    judged = unreachable(gap, np.zeros_like(now), velocity, now)
    assert dict(zip(cases, judged.tolist(), strict=True)) == {k: c[3] for k, c in cases.items()}


def _walkers(t_s: float) -> tuple[list[str], np.ndarray]:
    """Two people walking at 1.3 m/s, 3 m apart."""
    x = 1.3 * (t_s - START_S)
    return ["a", "b"], np.array([[x, 0.0], [x, 3.0]])


def test_a_clock_that_jumps_forward_and_back_restarts_and_forecasts_resume(
    caplog: pytest.LogCaptureFixture,
) -> None:
    session = Predictor.from_checkpoint().stream(online_calibration=True)
    times = [START_S + 0.4 * k for k in range(12)]
    for t in times:
        forecast = session.update(t, *_walkers(t))
    assert len(forecast) == 2
    future = times[-1] + 60.0  # one message stamped a minute ahead
    session.update(future, *_walkers(times[-1] + 0.4))
    answered = []
    for k in range(1, 4):  # then the tracker's own stamps again
        t = times[-1] + 0.4 * k
        answered.append(len(session.update(t, *_walkers(t))))
    assert answered[1:] == [2, 2]  # forecasts again within two messages
    assert session.faults.clock_resets == 2 and session.faults.late == 0
    assert "the clock jumped forward" in caplog.text and "the clock jumped back" in caplog.text
    # A late message is dropped and counted, never a reason to refuse the next ones.
    with pytest.raises(LateUpdateError):
        session.update(t - 0.2, *_walkers(t - 0.2))
    assert len(session.update(t + 0.4, *_walkers(t + 0.4))) == 2
    assert session.faults.late == 1


def test_frame_numbers_that_restart_restart_the_history() -> None:
    session = Predictor.from_checkpoint().stream()
    for frame in range(1000, 1100, 10):
        session.update(frame, [1, 2], np.array([[0.05 * frame, 0.0], [0.0, 0.05 * frame]]))
    assert len(session.update(0, [1, 2], [[0.0, 0.0], [0.0, 1.0]])) == 0  # a new count
    assert len(session.update(10, [1, 2], [[0.5, 0.0], [0.0, 1.5]])) == 2
    assert session.faults.clock_resets == 1


def test_a_reused_id_restarts_with_a_warning_and_no_fast_forecast(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """At 10 Hz, ``a`` walks +x at 1.3 m/s, vanishes for 0.5 s and its id comes back 4 m away
    on someone walking the other way."""
    session = Predictor.from_checkpoint().stream()
    worst = 0.0
    for k in range(80):
        t = START_S + 0.1 * k
        if 40 <= k < 45:
            continue  # not seen for 0.5 s
        x = 1.3 * 0.1 * k if k < 40 else 1.3 * 4.0 + 4.0 - 1.3 * 0.1 * (k - 45)
        forecast = session.update(t, ["a", "b"], np.array([[x, 0.0], [0.0, 1.2 * 0.1 * k]]))
        if "a" in list(forecast.ids):
            i = list(forecast.ids).index("a")
            path = np.vstack([[x, 0.0], forecast.point[i]])
            metres = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
            worst = max(worst, metres / (0.4 * forecast.point.shape[1]))
    assert "id a reappeared where no walker gets to" in caplog.text
    assert session.faults.id_restarts == 1
    assert worst < 3.0  # m/s, mean over the horizon
