"""What to tell a user whose file did not read as they ran it: the layout its header names,
the options a row every video frame needs, or the frame rate (or time unit) at which its
people walk at a usual pace. Hints only: nothing here refuses data."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.data.formats.fields import header_column, read_text_file
from grouptron.data.formats.spelling import OptionSpelling

_SEPARATOR = re.compile(r"\s*,\s*|\s+")
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")

WALKING_SPEED_MPS = 1.3
"""A usual walking pace: what a recording's median speed is near when its times are right."""
USUAL_MEDIAN_MPS = (0.3, 2.0)
"""Median speeds that question no time scale (UCY's crowded students walk at 0.5 m/s)."""
LIKELY_RATES = (1, 2, 2.5, 5, 6, 7.5, 10, 12, 12.5, 15, 20, 24, 25, 30, 50, 60, 100, 120)
"""Frame rates a time column is likely counted in; milli-, micro- and nanoseconds follow."""
_TIME_UNITS: dict[float, str] = {1e3: "milliseconds", 1e6: "microseconds", 1e9: "nanoseconds"}


def layout_from_header(fields: Sequence[str]) -> tuple[str, str | None] | None:
    """What a header line such as ``time_s,person,x_cm,y_cm`` says of the layout: the
    ``columns`` it names (``t,id,x,y``; unknown names as ``-``) and the units its x and y
    carry (``cm``; None when unstated), or None when it names no id, x, y and time."""
    columns, units = [], None
    for field in fields:
        found, unit = header_column(field)
        units = unit or units
        columns.append(found)
    named = [c for c in columns if c != "-"]
    has_time = named.count("t") + named.count("frame") == 1
    if not has_time or any(named.count(c) != 1 for c in ("id", "x", "y")):
        return None
    while columns and columns[-1] == "-":  # columns past the named ones are ignored anyway
        columns.pop()
    return ",".join(columns), units


def header_hint(line: str, spelling: OptionSpelling) -> str:
    """``; its header 'person,time_s,x,y' reads as --columns id,t,x,y`` for a first ``line``
    that names a whole layout, else ""."""
    fields = [f for f in _SEPARATOR.split(line.strip()) if f]
    layout = None if any(_NUMBER.fullmatch(f) for f in fields) else layout_from_header(fields)
    if layout is None:
        return ""
    columns, units = layout
    options = [spelling.setting("columns", columns)]
    options += [spelling.setting("units", units)] if units not in (None, "m") else []
    return f"; its header {line.strip()[:60]!r} reads as {' '.join(options)}"


def layout_hint(path: Path, spelling: OptionSpelling, *, off_grid: bool) -> str:
    """What to tell a file read as ``frame id x y`` that did not read: what its header line
    says of its layout, else (for frames off the grid) that it may need its frame rate."""
    text = read_text_file(path)
    first = next((ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")), "")
    hint = header_hint(first, spelling)
    if hint or not off_grid:
        return hint
    # The usual cause: a row every video frame (25 fps, 16 fps), or another column order.
    return (
        f"; if the file has a row for every video frame, give its frame rate "
        f"({spelling.setting('fps', 25)}, say); if its columns are not frame, id, x, y, "
        f"give their order ({spelling.setting('columns', 'id,frame,x,y')})"
    )


@dataclass(frozen=True)
class TimeScale:
    """What a recording's times say of their own scale, as they were read.

    Attributes:
        rate: counts of the time column per second as read: a frame column's fps, 1 for
            seconds.
        median_speed_mps: the median speed between consecutive observations of a person
            (NaN when nobody is seen twice).
        interval_s: the median time between consecutive observations of a person.
        span_s: from the recording's first time to its last.
        longest_s: the longest anyone is seen for, first observation to last.
        likely_rate: the likely rate at which the median speed is a walking pace; None where
            it already is one (``USUAL_MEDIAN_MPS``), or no rate explains it.
    """

    rate: float
    median_speed_mps: float
    interval_s: float
    span_s: float
    longest_s: float
    likely_rate: float | None

    @property
    def stretch(self) -> float:
        """How many times longer every time is at ``likely_rate`` than as read."""
        return self.rate / self.likely_rate if self.likely_rate else 1.0


def time_scale(ped_id: np.ndarray, time_s: np.ndarray, pos_m: np.ndarray, rate: float) -> TimeScale:
    """The :class:`TimeScale` of (R,) ids, (R,) seconds and (R, 2) metres whose time column
    was read at ``rate`` counts per second (any row order)."""
    order = np.lexsort((time_s, ped_id))
    ids, t, pos = ped_id[order], time_s[order], pos_m[order]
    same = ids[1:] == ids[:-1]
    dt = np.diff(t)
    moved = same & (dt > 0)  # consecutive observations of one person
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1)[moved] / dt[moved]
    first = np.flatnonzero(np.concatenate([[True], ~same]))
    last = np.append(first[1:] - 1, len(t) - 1)
    median = float(np.median(speed)) if speed.size else math.nan
    return TimeScale(
        rate=rate,
        median_speed_mps=median,
        interval_s=float(np.median(dt[moved])) if speed.size else math.nan,
        span_s=float(t.max() - t.min()) if len(t) else 0.0,
        longest_s=float((t[last] - t[first]).max()) if len(t) else 0.0,
        likely_rate=_likely_rate(median, rate),
    )


def _likely_rate(median_mps: float, rate: float) -> float | None:
    """The usual rate (a frame rate, or thousands, millions or billions a second) within 1.5
    times the one at which people would walk at ``WALKING_SPEED_MPS``, where the median is no
    usual pace and the rate is not ``rate``; None where there is none."""
    low, high = USUAL_MEDIAN_MPS
    if not median_mps > 0 or low <= median_mps <= high:  # NaN or 0: nothing to judge by
        return None
    wanted = rate * WALKING_SPEED_MPS / median_mps
    nearest = min((*LIKELY_RATES, *_TIME_UNITS), key=lambda r: abs(math.log(r / wanted)))
    if abs(math.log(nearest / wanted)) > math.log(1.5) or math.isclose(nearest, rate, rel_tol=0.25):
        return None
    return float(nearest)


def time_scale_hint(scale: TimeScale, columns: Sequence[str], spelling: OptionSpelling) -> str:
    """What a recording's walking speeds say of its time column, in one clause: how it reads
    now, the rate at which people walk at a usual pace, and the options that read it so (""
    where they already do). ``columns``: the layout it was read with."""
    rate = scale.likely_rate
    if rate is None:
        return ""
    fps = int(rate) if rate == int(rate) else rate  # --fps 1000000, not 1e+06
    fix, seconds = spelling.setting("fps", fps), "t" in columns
    now = (
        f"{'in seconds' if seconds else f'at {scale.rate:g} fps'} it spans "
        f"{duration(scale.span_s)} and people walk at {scale.median_speed_mps:.2g} m/s (median)"
    )
    then = (
        f"it spans {duration(scale.span_s * scale.stretch)} and they walk at "
        f"{scale.median_speed_mps / scale.stretch:.2g} m/s"
    )
    if not seconds:
        return f"{now}; if its frames are at {fps:g} fps, {then}: read it with {fix}"
    as_frames = spelling.setting("columns", ",".join("frame" if c == "t" else c for c in columns))
    unit = _TIME_UNITS.get(int(rate)) if float(rate).is_integer() else None
    what = f"times look like {unit}, in which" if unit else f"as frames at {fps:g} fps"
    joiner = " " if spelling.style == "flags" else ", "
    return f"{now}; {what} {then}: read them with {as_frames}{joiner}{fix}"


def duration(seconds: float) -> str:
    """``"9.96 s"``, ``"30.2 min"``, ``"5.03 h"`` or ``"20.9 days"``."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def not_a_number(fields: Sequence[str], columns: Sequence[str]) -> str:
    """Why a row of ``fields`` laid out as ``columns`` is no row of numbers, naming the column
    (ids must be numbers: names such as ``ped_1`` need mapping to integers first)."""
    for field, column in zip(fields, columns, strict=False):
        if not _NUMBER.fullmatch(field) and field.lower() not in ("nan", "inf", "-inf"):
            why = f"{column} is not a number: {field[:40]!r}"
            if column == "id":
                why += " (ids must be integers: map names such as 'ped_1' to numbers first)"
            return why
    return f"not a number in {' '.join(fields)[:60]!r}"
