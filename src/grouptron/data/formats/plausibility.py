"""Whether a recording reads as it was recorded: walking speeds no pedestrian has (units or
frame rate wrong) are refused, and a time column misread (milliseconds as seconds, a wrong
frame rate) is named with the rate at which people walk at a usual pace."""

from __future__ import annotations

import logging

import numpy as np

from grouptron.constants import DT_S, HISTORY_STEPS, HORIZON_STEPS, UNITS_M
from grouptron.data.formats.glitches import MAX_MEDIAN_SPEED_MPS
from grouptron.data.formats.hints import TimeScale, time_scale, time_scale_hint
from grouptron.data.formats.layout import Recording, RecordingFormat
from grouptron.data.formats.reader import MAX_GRID_CELLS
from grouptron.errors import GrouptronError

log = logging.getLogger(__name__)


def recording_time_scale(recording: Recording) -> TimeScale:
    """What the recording's times say of their scale (:class:`TimeScale`), at the rate its
    time column was read: its frame rate, or 1 for seconds."""
    per_frame = recording.seconds_per_frame
    rate = 1.0 if per_frame is None else 1.0 / per_frame
    return time_scale(recording.ped_id, recording.time_s, recording.pos_m, rate)


def time_hint(recording: Recording, fmt: RecordingFormat, scale: TimeScale | None = None) -> str:
    """``; `` and :func:`time_scale_hint` for a file whose time column ``fmt`` reads, else
    "" (as for a TrajNet++ file or a bag, whose own times are read)."""
    if recording.own_times:
        return ""
    hint = time_scale_hint(scale or recording_time_scale(recording), fmt.columns, fmt.spelling)
    return "; " + hint if hint else ""


def check_plausible(
    recording: Recording, fmt: RecordingFormat, scale: TimeScale | None = None
) -> None:
    """Refuse a recording whose median walking speed is above 3 m/s: a unit or frame-rate
    mistake (a file in centimetres read as metres walks at 100 m/s). ``scale``: the
    recording's :func:`recording_time_scale`, where known."""
    scale = scale or recording_time_scale(recording)
    median = scale.median_speed_mps
    if median > MAX_MEDIAN_SPEED_MPS:
        walking = [u for u in ("cm", "mm") if 0.2 <= median * UNITS_M[u] / UNITS_M[fmt.units] < 3]
        spelling = fmt.spelling
        hints = [spelling.setting("units", u) for u in walking]
        raise GrouptronError(
            f"{recording.path}: the median walking speed is {median:.3g} m/s, implausible for "
            f"pedestrians (read with {spelling.setting('units', fmt.units)}"
            f"{'' if fmt.time_column == 't' else f', {1 / fmt.seconds_per_frame:g} fps'}); "
            f"check the units{' (' + ' or '.join(hints) + '?)' if hints else ''} and "
            f"{fmt.option('fps')}, or pass {spelling.setting('check_speed', False)} to go on"
            f"{'' if hints else time_hint(recording, fmt, scale)}"
        )


def check_time_scale(
    recording: Recording, fmt: RecordingFormat, scale: TimeScale, dt_s: float = DT_S
) -> None:
    """Where walking speeds say the time column is misread (``scale.likely_rate``), refuse a
    recording whose tracks would break at nearly every observation, or that would be too
    large to process, naming the likely rate; warn, naming it, where nobody is seen long
    enough for a forecast to be scored (the commands then fail for want of samples)."""
    hint = time_hint(recording, fmt, scale)
    if not hint:
        return
    if scale.interval_s > fmt.max_gap_s:
        raise GrouptronError(
            f"{recording.path}: a person's consecutive observations are {scale.interval_s:.3g} s "
            f"apart (median), longer than {fmt.option('max_gap_s')} {fmt.max_gap_s:g} s, so "
            f"nearly every track would break{hint}"
        )
    people, steps = len(np.unique(recording.ped_id)), int(scale.span_s / dt_s) + 1
    if people * steps > MAX_GRID_CELLS:
        raise GrouptronError(
            f"{recording.path}: {people} people over {steps:,} steps of {dt_s} s is too large "
            f"to process at once{hint}"
        )
    needed_s = (HISTORY_STEPS + HORIZON_STEPS - 1) * dt_s
    if scale.longest_s < needed_s:
        wanted = f"{HISTORY_STEPS} observed and {HORIZON_STEPS} future steps of {dt_s:g} s"
        log.warning("%s: nobody is seen for %.3g s (%s)%s", recording.path, needed_s, wanted, hint)
