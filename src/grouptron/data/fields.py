"""Fields of text tables and checks of their numbers, shared by every track reader.

A line is split on commas when it has one, else on whitespace. An empty comma-separated field
is a missing value: merging it away would shift every column after it, so it is refused.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from grouptron.errors import DataFormatError

MAX_WHOLE_NUMBER = 2**53
"""float64 stops counting in ones above this: frame numbers and ids beyond it are rounded."""
_EMPTY_COMMA_FIELD = re.compile(r"(^|,)[ \t]*,", re.MULTILINE)


class EmptyFieldError(ValueError):
    """A comma-separated line with an empty field."""


def split_fields(line: str) -> list[str]:
    """The fields of one line; [] for a blank line or one of commas only. One trailing comma
    ends the line without adding a field.

    Raises:
        EmptyFieldError: for an empty comma-separated field, such as ``1,,2,3``.
    """
    text = line.strip()
    if "," not in text:
        return text.split()
    fields = [field.strip() for field in text.removesuffix(",").split(",")]
    if not any(fields):
        return []
    if "" in fields:
        raise EmptyFieldError(f"an empty field in {text[:60]!r}")
    return fields


def has_empty_field(text: str) -> bool:
    """Whether any line of ``text`` has an empty comma-separated field (a whole-file test for
    parsers that cannot tell, before they run)."""
    return _EMPTY_COMMA_FIELD.search(text) is not None


def refuse_bad_numbers(
    source: Path,
    values: np.ndarray,
    lines: np.ndarray,
    names: Mapping[int, str],
    whole: Sequence[int] = (),
) -> None:
    """Refuse, naming ``source`` and the line, the first value of a named column that is not
    finite, then the first value of a ``whole`` column that is not a whole number or is too
    large to count exactly.

    Args:
        values: (R, C) the numbers read.
        lines: (R,) the file line (or row number) of every row.
        names: column index -> the name to print, for every column to check.
        whole: the indices of columns that hold whole numbers (frames, ids).
    """
    for column, name in names.items():
        bad = np.flatnonzero(~np.isfinite(values[:, column]))
        if bad.size:
            raise DataFormatError(source, f"{name} is not finite", int(lines[bad[0]]))
    for column in whole:
        name, column_values = names[column], values[:, column]
        bad = np.flatnonzero(column_values != np.round(column_values))
        if bad.size:
            why = f"{name} must be a whole number, not {column_values[bad[0]]:g}"
            raise DataFormatError(source, why, int(lines[bad[0]]))
        bad = np.flatnonzero(np.abs(column_values) > MAX_WHOLE_NUMBER)
        if bad.size:
            why = f"{name} {column_values[bad[0]]:.3g} is out of range (|{name}| <= 2**53)"
            raise DataFormatError(source, why, int(lines[bad[0]]))
