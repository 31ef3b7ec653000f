"""Time windows of recordings: the part of a track table between two steps, and where a cut
in minutes falls across recordings played one after the other (site adaptation and its
held-out part)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from grouptron.data.formats.reader import TrackTable


def step_window(table: TrackTable, first_step: int, end_step: int) -> TrackTable | None:
    """The rows of ``table`` with ``first_step <= step < end_step``, steps counted again from
    the window's start (frames unchanged); None where no row falls inside. A track that
    crosses an edge keeps its rows inside only."""
    keep = (table.step >= first_step) & (table.step < end_step)
    if not keep.any():
        return None
    return dataclasses.replace(
        table,
        first_frame=table.first_frame + first_step * table.frames_per_step,
        ped_id=table.ped_id[keep],
        track=table.track[keep],
        step=table.step[keep] - first_step,
        pos_m=table.pos_m[keep],
    )


@dataclass(frozen=True)
class Windows:
    """Recordings played one after the other, cut in two windows.

    Attributes:
        first: per recording, the steps ``[0, end)`` inside the first window.
        last: per recording, the steps ``[start, num_steps)`` inside the last window.
        total_s: the recordings' summed duration.
    """

    first: tuple[int, ...]
    last: tuple[int, ...]
    total_s: float


def cut_windows(num_steps: Sequence[int], first_s: float, last_s: float, dt_s: float) -> Windows:
    """Where a first window of ``first_s`` seconds from the start and a last window of
    ``last_s`` seconds before the end fall in recordings of ``num_steps`` steps each, played
    in order. The windows never overlap: the caller checks ``first_s + last_s <= total_s``."""
    total_steps = sum(num_steps)
    first_end = round(first_s / dt_s)
    last_start = total_steps - round(last_s / dt_s)
    firsts, lasts, offset = [], [], 0
    for steps in num_steps:
        firsts.append(min(max(first_end - offset, 0), steps))
        lasts.append(min(max(last_start - offset, 0), steps))
        offset += steps
    return Windows(tuple(firsts), tuple(lasts), total_steps * dt_s)
