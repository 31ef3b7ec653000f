"""Missed detections: short gaps in a track filled by linear interpolation.

A tracker that misses a person for a step or two would otherwise restart their track, and a
restarted track has too little history to forecast from. Filling is causal: a gap is filled
only once the person is seen again, from the two observations around it.
"""

from __future__ import annotations

import numpy as np


def bridge_gaps(
    rows: np.ndarray, frames_per_step: int, max_missed_steps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Fill each run of at most ``max_missed_steps`` missing steps inside a track.

    Args:
        rows: (R, 4) ``frame, id, x, y`` rows; frames on a grid of ``frames_per_step``.
        frames_per_step: frames between steps.
        max_missed_steps: longest run of missing steps filled (0 fills nothing); longer gaps are
            left alone (the track is split there, as before).

    Returns:
        (R + F, 4) the rows followed by the F filled ones, and (R + F,) True on the filled rows.
    """
    unfilled = rows, np.zeros(len(rows), dtype=bool)
    if max_missed_steps <= 0 or len(rows) < 2:
        return unfilled
    ordered = rows[np.lexsort((rows[:, 0], rows[:, 1]))]  # by id, then frame
    frame_gap = np.diff(ordered[:, 0])
    on_grid = np.mod(frame_gap, frames_per_step) == 0  # off-grid frames are the reader's to refuse
    missing = np.where(
        (ordered[1:, 1] == ordered[:-1, 1]) & on_grid,
        np.rint(frame_gap / frames_per_step).astype(np.int64) - 1,
        0,
    )  # (R-1,) steps missing between consecutive rows of one id
    fill = (missing >= 1) & (missing <= max_missed_steps)
    if not fill.any():
        return unfilled
    count = missing[fill]  # (G,) rows to add per gap
    before, after = ordered[:-1][fill], ordered[1:][fill]  # (G, 4)
    gap = np.repeat(np.arange(len(count)), count)  # (F,) gap of every filled row
    k = np.arange(len(gap)) - np.repeat(np.cumsum(count) - count, count) + 1  # (F,) 1..count
    fraction = (k / (count[gap] + 1))[:, None]
    filled = before[gap] + (after[gap] - before[gap]) * fraction
    filled[:, 0] = before[gap, 0] + k * frames_per_step  # exact frames, not interpolated floats
    filled[:, 1] = before[gap, 1]
    is_filled = np.concatenate([np.zeros(len(rows), dtype=bool), np.ones(len(filled), dtype=bool)])
    return np.concatenate([rows, filled]), is_filled


def filled_in_histories(
    ids: np.ndarray,
    frame: int,
    history_points: np.ndarray,
    filled: np.ndarray,
    *,
    frames_per_step: int,
) -> np.ndarray:
    """How many filled positions each of N forecasts' histories holds.

    Args:
        ids: (N,) the forecast agents' ids.
        frame: the forecast frame, the last of every history.
        history_points: (N,) history lengths in steps (the last ones up to ``frame``).
        filled: (F, 2) ``frame, id`` of the rows ``bridge_gaps`` filled.
        frames_per_step: frames between steps.

    Returns:
        (N,) filled positions inside each history.
    """
    if len(filled) == 0 or len(ids) == 0:
        return np.zeros(len(ids), dtype=np.int64)
    oldest = frame - (history_points - 1) * frames_per_step  # (N,)
    filled_frame, filled_id = filled[None, :, 0], filled[None, :, 1]  # (1, F)
    inside = (filled_id == ids[:, None]) & (filled_frame >= oldest[:, None])
    inside &= filled_frame <= frame  # (N, F)
    return inside.sum(axis=1)
