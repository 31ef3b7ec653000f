"""One plausibility rule for tracks from files, arrays and streams: no impossible jumps.

A tracker's glitch (one detection at x = 5000 m instead of 11.5 m) must not reach the model:
it would send that person's forecast kilometres away and, through the edge encoder, bend the
forecasts of everyone near them. Between two sightings of one person nobody moves faster than
``MAX_JUMP_SPEED_MPS``; a pair that does is explained, in this order, as

- a **spike**: one sighting away and back (its neighbours are plausible from each other): its
  position is replaced by linear interpolation between them;
- an impossible **first or last** sighting of a track (the rest is plausible): dropped;
- otherwise a jump that **persists** (an id swap, a tracker restart): the track is split there.

Pure functions on (R,) ids, (R,) seconds and (R, 2) metres in any row order; the readers and
the predictor apply the result and warn, naming each row.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

MAX_JUMP_SPEED_MPS = 15.0
"""Faster than anyone runs: a jump this fast between two sightings is not a walk."""
MAX_MEDIAN_SPEED_MPS = 3.0
"""A median walking speed above this is not pedestrians in metres: wrong units or frame rate.
Jumps are judged only below it: tracks in centimetres are refused as a whole, with a hint,
not split at every step."""

_SLACK_M = 1e-6
"""Rounding slack on a distance (metres), so that a file's decimals never make a jump."""


@dataclass(frozen=True)
class Glitches:
    """What :func:`find_glitches` found; row indices are in the caller's row order."""

    spikes: np.ndarray
    """(S,) rows replaced by interpolation between the person's sightings around them."""
    dropped: np.ndarray
    """(D,) impossible first or last sightings of a track."""
    splits: np.ndarray
    """(J,) rows where a jump that persists starts a new track."""
    pos_m: np.ndarray
    """(R, 2) the positions with every spike interpolated."""
    jump_m: np.ndarray
    """(R,) for each row above, how far it is from the sighting before it (metres)."""

    def __len__(self) -> int:
        return len(self.spikes) + len(self.dropped) + len(self.splits)

    @property
    def keep(self) -> np.ndarray:
        """(R,) False on the dropped rows."""
        keep = np.ones(len(self.pos_m), dtype=bool)
        keep[self.dropped] = False
        return keep


def median_speed_mps(ped_id: np.ndarray, time_s: np.ndarray, pos_m: np.ndarray) -> float:
    """The median speed between consecutive observations of the same person (NaN when no
    person is seen twice): (R,) ids, (R,) seconds, (R, 2) metres."""
    order = np.lexsort((time_s, ped_id))
    ids, t, pos = ped_id[order], time_s[order], pos_m[order]
    same = (ids[1:] == ids[:-1]) & (t[1:] > t[:-1])
    if not same.any():
        return float("nan")
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1)[same] / np.diff(t)[same]
    return float(np.median(speed))


def find_glitches(
    ped_id: np.ndarray,
    time_s: np.ndarray,
    pos_m: np.ndarray,
    max_speed_mps: float = MAX_JUMP_SPEED_MPS,
) -> Glitches:
    """The impossible jumps of (R,) ``ped_id`` tracks at (R,) ``time_s`` seconds and (R, 2)
    ``pos_m`` metres (rows in any order; times of one person distinct); none while the tracks'
    median speed is implausible (``MAX_MEDIAN_SPEED_MPS``: the units are wrong, not the rows)."""
    rows = len(ped_id)
    empty = np.zeros(0, dtype=np.int64)
    nothing = Glitches(empty, empty, empty, pos_m.astype(np.float64), np.zeros(rows))
    if not median_speed_mps(ped_id, time_s, pos_m) <= MAX_MEDIAN_SPEED_MPS:
        return nothing
    order = np.lexsort((time_s, ped_id))  # by person, then time
    ids, t, p = ped_id[order], time_s[order], pos_m[order].astype(np.float64)
    same = ids[1:] == ids[:-1]  # (R-1,) pair k joins rows k and k+1

    def fast(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        metres = np.linalg.norm(p[b] - p[a], axis=1)
        return metres > max_speed_mps * np.abs(t[b] - t[a]) + _SLACK_M

    pair = np.arange(rows - 1)
    jump = same & fast(pair, pair + 1)  # (R-1,)
    if not jump.any():
        return nothing
    spike, drop, split = _explain_jumps(jump, same, fast)
    fixed = p.copy()
    s = np.flatnonzero(spike)
    weight = ((t[s] - t[s - 1]) / (t[s + 1] - t[s - 1]))[:, None]
    fixed[s] = p[s - 1] * (1 - weight) + p[s + 1] * weight
    distance = np.zeros(rows)  # from the sighting before (the first row: the one after)
    distance[1:] = np.where(same, np.linalg.norm(np.diff(p, axis=0), axis=1), 0.0)
    first = np.flatnonzero(drop & ~np.concatenate([[False], same]))
    distance[first] = np.linalg.norm(p[first + 1] - p[first], axis=1)
    pos_out, jump_out = np.empty_like(fixed), np.empty(rows)
    pos_out[order], jump_out[order] = fixed, distance
    return Glitches(
        spikes=np.sort(order[spike]),
        dropped=np.sort(order[drop]),
        splits=np.sort(order[split]),
        pos_m=pos_out,
        jump_m=jump_out,
    )


def _explain_jumps(
    jump: np.ndarray, same: np.ndarray, fast: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R,) spike, dropped and split masks of rows sorted by person and time, from the (R-1,)
    ``jump`` and ``same``-person masks of consecutive pairs; ``fast(a, b)`` tells whether rows
    ``a`` and ``b`` are too far apart."""
    rows = len(jump) + 1
    before = np.concatenate([[False], jump])  # (R,) the pair before the row jumps
    after = np.concatenate([jump, [False]])
    joined_before = np.concatenate([[False], same])
    joined_after = np.concatenate([same, [False]])
    inner = np.flatnonzero(joined_before & joined_after)
    bridge = np.zeros(rows, dtype=bool)
    bridge[inner] = ~fast(inner - 1, inner + 1)  # the sightings around it agree
    candidate = before & after & bridge
    # Two candidates side by side (bad, good, bad: the good row's neighbours agree with each
    # other too) cannot tell which is the glitch: neither is interpolated, the jumps split.
    beside = np.concatenate([[False], candidate[:-1]]) | np.concatenate([candidate[1:], [False]])
    spike = candidate & ~beside
    # An impossible end of a track, the pair next to it plausible (a track of three at least).
    next_ok = np.concatenate([joined_after[1:] & ~after[1:], [False]])
    prev_ok = np.concatenate([[False], joined_before[:-1] & ~before[:-1]])
    drop = (~joined_before & after & next_ok) | (~joined_after & before & prev_ok)
    explained = spike | drop
    # A jump that no spike or dropped end explains splits the track at its later row.
    split = np.concatenate([[False], jump & ~explained[:-1] & ~explained[1:]])
    return spike, drop, split


def repair_observations(
    source: Path, ped_id: np.ndarray, time_s: np.ndarray, pos_m: np.ndarray, lines: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A file's observations with their jumps repaired and named (file lines) in a warning:
    (R,) rows kept, (R, 2) positions (spikes interpolated), (R,) True where a new track starts
    (a jump that persists). Rows in the caller's order."""
    found = find_glitches(ped_id, time_s, pos_m)
    if len(found):
        named = describe_glitches(found, ped_id, pos_m, lambda r: f"line {lines[r]}")
        log.warning("%s: %s", source, named)
    split = np.zeros(len(ped_id), dtype=bool)
    split[found.splits] = True
    return found.keep, found.pos_m, split


def repair_rows(
    rows: np.ndarray, seconds_per_frame: float, fresh_id: float | None = None
) -> tuple[np.ndarray, Glitches]:
    """(R', 4) ``frame, id, x, y`` rows with their impossible jumps repaired, and what was
    found (row indices of ``rows``). Spikes are interpolated and dropped rows removed; a jump
    that persists leaves the sightings before it under a fresh id (above every id), so the
    person's track starts again at the jump while its ids stay the caller's (``fresh_id``: the
    first free id, when other rows than these use ids too)."""
    found = find_glitches(rows[:, 1], rows[:, 0] * seconds_per_frame, rows[:, 2:4])
    if not len(found):
        return rows, found
    fixed = rows.copy()
    fixed[:, 2:4] = found.pos_m
    fresh = float(rows[:, 1].max()) + 1 if fresh_id is None else max(fresh_id, rows[:, 1].max() + 1)
    for split in found.splits.tolist():  # a handful of jumps, never one per sample
        before = (fixed[:, 1] == fixed[split, 1]) & (fixed[:, 0] < fixed[split, 0])
        fixed[before, 1], fresh = fresh, fresh + 1
    return fixed[found.keep], found


def describe_glitches(
    glitches: Glitches, ped_id: np.ndarray, pos_m: np.ndarray, where: Callable[[int], str]
) -> str:
    """One line for a warning: how many rows were repaired and how, the first three (in row
    order) named by ``where(row)`` (a file line, an array row); only those are formatted."""
    kinds = ("replaced by interpolation", "dropped", "starts a new track")
    found = (glitches.spikes, glitches.dropped, glitches.splits)
    rows = np.concatenate(found)
    kind = np.repeat(np.arange(len(kinds)), [len(f) for f in found])
    first = np.argsort(rows, kind="stable")[:3]
    shown = "; ".join(
        f"{where(r)} (id {int(ped_id[r])}, x={pos_m[r, 0]:.6g}, y={pos_m[r, 1]:.6g}) is "
        f"{glitches.jump_m[r]:.4g} m from the track: {kinds[k]}"
        for r, k in zip(rows[first].tolist(), kind[first].tolist(), strict=True)
    )
    more = f"; and {len(rows) - 3} more" if len(rows) > 3 else ""
    return (
        f"{len(rows)} impossible jump(s) (faster than {MAX_JUMP_SPEED_MPS:g} m/s between "
        f"sightings): {shown}{more}"
    )
