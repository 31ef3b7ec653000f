"""What a live tracker gets wrong, judged at each update: clocks that jump, messages that
arrive late, and ids that come back on someone else.

Pure functions and constants; the live session (``inference.stream``) applies them, warns and
counts (``StreamFaults``). The thresholds:

- **Late.** A stamp at most ``LATE_TOLERANCE_S`` before the previous update's is a message that
  arrived out of order (several sensors, a network's reordering): it is dropped and counted,
  and the session goes on as if it never came.
- **Clock jumps.** A stamp more than ``LATE_TOLERANCE_S`` before the previous one, or more than
  ``JUMP_FORWARD_S`` after it, is a clock that jumped (a stamp in the future, a time source
  reset, simulated time restarted, a bag that loops), not people walking: the history restarts
  from that message, with one named warning, and forecasts resume as soon as people have two
  steps of history again. No stamp is refused for ever.
- **Reappearances no walker makes.** A person seen again after a gap (more than
  ``REAPPEARANCE_GAP_S`` since their last sighting) of ``gap_s`` seconds is judged
  against where their last velocity would have taken them: a walker changes velocity by at
  most ``MAX_ACCELERATION_MPS2`` (a hard start or stop; walking is about 1 m/s², a sprint's
  start about 4), so a sighting farther than ``0.5 a gap_s^2 + POSITION_NOISE_M`` from
  ``last + velocity * gap_s`` is someone else under a reused id, or an id swap; so is any move
  faster than ``MAX_JUMP_SPEED_MPS``. Over a 0.5 s gap that allows 1.0 m: a reused id 4 m away
  (8 m/s over the gap) or walking back the way it came is caught, a walker or a runner who
  keeps their pace is not. The track restarts there, with a warning naming the id. Between
  sightings without a gap only ``MAX_JUMP_SPEED_MPS`` applies: a tracker's noise from one
  message to the next is not a reused id: on the real crowds of the deployment model's
  training data, 0.3% (Grand Central) to 1.0% (Edinburgh) of consecutive 0.4 s steps depart
  further from constant velocity than the bound allows, while as shipped 0.005% restart, all
  at the 15 m/s bound (``benchmarks/track_faults.py``).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from grouptron.data.formats.glitches import MAX_JUMP_SPEED_MPS

LATE_TOLERANCE_S = 1.0
"""A stamp this much (or less) before the previous update's is late: dropped and counted."""
JUMP_FORWARD_S = 10.0
"""A stamp this much after the previous update's is a clock that jumped forward: longer than
any history a forecast reads (3.6 s) with room for a tracker that paused."""
MAX_ACCELERATION_MPS2 = 4.0
"""The largest change of velocity a walker makes per second (a sprint's start)."""
POSITION_NOISE_M = 0.5
"""A tracker's position error allowed on top of the acceleration bound."""
REAPPEARANCE_GAP_S = 0.45
"""Sightings further apart than this (one model step, with room for a tracker's jitter) are a
reappearance, judged by the acceleration bound."""
VELOCITY_BASE_S = 0.4
"""A person's last velocity is measured over this much of their track before the gap (one
model step): over a tracker's own 0.03-0.1 s interval its noise would dominate."""


class Clock(enum.Enum):
    """How an update's time stands to the previous update's."""

    NEXT = "next"
    LATE = "late"
    JUMPED_BACK = "jumped back"
    JUMPED_FORWARD = "jumped forward"


def clock_step(previous_s: float | None, t_s: float) -> Clock:
    """How ``t_s`` follows ``previous_s`` (None: the first update, always ``NEXT``)."""
    if previous_s is None or previous_s < t_s <= previous_s + JUMP_FORWARD_S:
        return Clock.NEXT
    if t_s > previous_s:
        return Clock.JUMPED_FORWARD
    return Clock.LATE if previous_s - t_s <= LATE_TOLERANCE_S else Clock.JUMPED_BACK


def unreachable(
    gap_s: np.ndarray, last_xy_m: np.ndarray, velocity_mps: np.ndarray, xy_m: np.ndarray
) -> np.ndarray:
    """(N,) whether each person, last seen at (N, 2) ``last_xy_m`` moving at (N, 2)
    ``velocity_mps`` (NaN where unknown), cannot be at (N, 2) ``xy_m`` (N,) ``gap_s`` seconds
    later: faster than anyone moves, or, after a gap and with a known velocity, beyond the
    acceleration bound (module docstring)."""
    gap_s = np.maximum(gap_s, 1e-9)
    moved_m = np.linalg.norm(xy_m - last_xy_m, axis=-1)
    too_fast = moved_m > MAX_JUMP_SPEED_MPS * gap_s
    expected = last_xy_m + np.nan_to_num(velocity_mps) * gap_s[:, None]
    off_m = np.linalg.norm(xy_m - expected, axis=-1)
    allowed_m = 0.5 * MAX_ACCELERATION_MPS2 * gap_s**2 + POSITION_NOISE_M
    judged = np.isfinite(velocity_mps).all(axis=-1) & (gap_s > REAPPEARANCE_GAP_S)
    result: np.ndarray = too_fast | (judged & (off_m > allowed_m))
    return result


def unreachable_rows(
    rows: np.ndarray, new: np.ndarray, step_frames: int, seconds_per_frame: float
) -> np.ndarray:
    """(J,) ids among the (N, 4) ``new`` rows (``frame, id, x, y``, one frame) whose last
    sighting in the (R, 4) window ``rows`` is one no walker gets to from (``unreachable``; the
    velocity from the sighting one step before it, where there is one)."""
    if not len(rows) or not len(new):
        return np.zeros(0)
    by_id = rows[np.lexsort((rows[:, 0], rows[:, 1]))]
    is_last = np.append(by_id[1:, 1] != by_id[:-1, 1], True)
    last = by_id[is_last]  # (P, 4) each person's last sighting
    before = by_id[np.maximum(np.flatnonzero(is_last) - 1, 0)]  # the one before it
    base = (before[:, 1] == last[:, 1]) & (last[:, 0] - before[:, 0] == step_frames)
    velocity = (last[:, 2:4] - before[:, 2:4]) / (step_frames * seconds_per_frame)
    velocity[~base] = np.nan
    at = np.searchsorted(last[:, 1], new[:, 1])
    seen = at < len(last)
    seen[seen] = last[at[seen], 1] == new[seen, 1]
    previous = last[at[seen]]
    gap_s = (new[seen, 0] - previous[:, 0]) * seconds_per_frame
    far = unreachable(gap_s, previous[:, 2:4], velocity[at[seen]], new[seen, 2:4])
    jumped: np.ndarray = new[seen][far, 1]
    return jumped


@dataclass
class StreamFaults:
    """What a live session has survived so far.

    Attributes:
        late: updates dropped because their time was slightly before the previous one's.
        clock_resets: times the clock jumped (back, or far forward) and the history restarted.
        id_restarts: tracks restarted because a person reappeared where no walker gets to.
    """

    late: int = 0
    clock_resets: int = 0
    id_restarts: int = 0
