"""What to tell a user whose file did not read as they ran it: the layout its header names,
or the options a row every video frame needs. Hints only: nothing here reads data."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from grouptron.data.fields import read_text_file
from grouptron.data.spelling import OptionSpelling

_SEPARATOR = re.compile(r"\s*,\s*|\s+")
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


_HEADER_NAMES = {
    "t": ("t", "time", "times", "timestamp", "sec", "secs", "second", "seconds", "time_s", "t_s"),
    "frame": ("frame", "frames", "frame_id", "frameid", "frame_number", "frame_num", "f"),
    "id": (
        "id", "person", "person_id", "ped", "ped_id", "pedestrian", "pedestrian_id", "track",
        "track_id", "trackid", "agent", "agent_id", "object", "object_id", "target", "target_id",
    ),
    "x": ("x", "pos_x", "position_x", "px", "x_pos"),
    "y": ("y", "pos_y", "position_y", "py", "y_pos"),
}  # fmt: skip
_UNIT_SUFFIX = re.compile(r"^(.*?)[_ ]?\(?(m|cm|mm)\)?$")


def layout_from_header(fields: Sequence[str]) -> tuple[str, str | None] | None:
    """What a header line such as ``time_s,person,x_cm,y_cm`` says of the layout: the
    ``columns`` it names (``t,id,x,y``; unknown names as ``-``) and the units its x and y
    carry (``cm``; None when unstated), or None when it names no id, x, y and time."""
    columns, units = [], None
    for field in fields:
        name = field.strip().lower()
        unit = None
        match = _UNIT_SUFFIX.match(name)
        if match and match.group(1):
            name, unit = match.group(1), match.group(2)
        found = next((c for c, names in _HEADER_NAMES.items() if name in names), "-")
        if found in ("x", "y") and unit:
            units = unit
        columns.append(found)
    named = [c for c in columns if c != "-"]
    has_time = named.count("t") + named.count("frame") == 1
    if not has_time or any(named.count(c) != 1 for c in ("id", "x", "y")):
        return None
    while columns and columns[-1] == "-":  # columns past the named ones are ignored anyway
        columns.pop()
    return ",".join(columns), units


def layout_hint(path: Path, spelling: OptionSpelling, *, off_grid: bool) -> str:
    """What to tell a file read as ``frame id x y`` that did not read: what its header line
    says of its layout, else (for frames off the grid) that it may need its frame rate."""
    text = read_text_file(path)
    first = next((ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")), "")
    fields = [f for f in _SEPARATOR.split(first.strip()) if f]
    layout = None if any(_NUMBER.fullmatch(f) for f in fields) else layout_from_header(fields)
    if layout is not None:
        columns, units = layout
        options = [spelling.setting("columns", columns)]
        options += [spelling.setting("units", units)] if units not in (None, "m") else []
        return f"; its header {first.strip()[:60]!r} reads as {' '.join(options)}"
    if off_grid:  # the usual cause: a row every video frame (25 fps, 16 fps), or another order
        return (
            f"; if the file has a row for every video frame, give its frame rate "
            f"({spelling.setting('fps', 25)}, say); if its columns are not frame, id, x, y, "
            f"give their order ({spelling.setting('columns', 'id,frame,x,y')})"
        )
    return ""


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
