"""Fields of text tables and checks of their numbers, shared by every track reader.

Fields are separated by commas, whitespace or both (``0 1,0.0, 1.0``). Two commas with only
whitespace between them, or a comma that starts a line, leave an empty field: a missing value
that merging away would shift every column after it. Commas that end a line (spreadsheet
padding) end it; a line whose first character is ``#`` is a comment.
"""

from __future__ import annotations

import io
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from grouptron.errors import DataFormatError

MAX_WHOLE_NUMBER = 2**53
"""float64 stops counting in ones above this: frame numbers and ids beyond it are rounded."""
_SEPARATOR = re.compile(r"\s*,\s*|\s+")
_EMPTY_INSIDE = re.compile(r",[ \t]*,")
_EMPTY_FIRST = re.compile(r"\n[ \t]*,")
_DECIMAL_COMMA = re.compile(r"[-+]?\d+,\d+(?:[eE][-+]?\d+)?")
_DIGIT_COMMA_DIGIT = re.compile(r"\d,\d")
_BLANK_INSIDE = re.compile(r"\S[ \t]+\S")


def read_text_file(path: Path) -> str:
    """A track or label file's text, or one line that says why not: missing, a folder, not
    UTF-8 (naming the line; "save it as UTF-8") or binary. A byte-order mark is no data."""
    if not path.exists():
        raise DataFormatError(path, "file not found")
    if not path.is_file():
        raise DataFormatError(path, "not a regular file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataFormatError(path, f"cannot read the file ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise DataFormatError(
            path,
            "not UTF-8 text (save the file as UTF-8, e.g. from a spreadsheet's CSV UTF-8)",
            line,
        ) from None
    if "\x00" in text:
        line = text[: text.index("\x00")].count("\n") + 1
        raise DataFormatError(path, "not a text file (contains NUL bytes)", line)
    return text


KNOWN_COLUMNS = ("frame", "id", "x", "y", "t")
"""Column names a layout gives meaning to: a header that uses them can be checked."""
# fmt: skip below: a table of synonyms read by name, several to a line (one a line: 40 lines).
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


def header_column(field: str) -> tuple[str, str | None]:
    """What a header's name says (``person`` -> ``("id", None)``, ``x_cm`` -> ``("x", "cm")``):
    the column it names (``-``: none the layout knows) and the units of an x or y."""
    name = field.strip().strip("\"'").lower()
    found = next((c for c, names in _HEADER_NAMES.items() if name in names), None)
    if found is not None:
        return found, None
    match = _UNIT_SUFFIX.match(name)
    if match and match.group(1):
        stem = next((c for c, names in _HEADER_NAMES.items() if match.group(1) in names), "-")
        return stem, match.group(2) if stem in ("x", "y") else None
    return "-", None


def _role(column: str) -> str:
    """What a column holds: ``time`` for both time columns, else its own name."""
    return "time" if column in ("t", "frame") else column


def refuse_header_disagreement(
    source: Path,
    header: Sequence[str],
    columns: Sequence[str],
    number: int,
    hint: str,
    *,
    time_as_frames: bool = False,
) -> None:
    """Refuse a header line whose names contradict the columns the file is read with (a file
    whose header says ``frame id y x`` read as ``frame id x y`` would be silently mirrored;
    ``person,time_s,x,y`` read as ``frame,id,x,y`` would take times for ids); names the layout
    does not know (``height``, ``z``) are not judged. ``time_as_frames``: a frame rate was
    given, so a column of times (seconds, milliseconds) may be read as frame numbers."""
    for index, (field, column) in enumerate(zip(header, columns, strict=False)):
        name = header_column(field)[0]
        said = field.strip().strip("\"'")
        if name == "-" or column not in KNOWN_COLUMNS or name == column:
            continue
        same_role = _role(name) == _role(column)  # 't' and 'frame': only the names judged
        if same_role and (said.lower() != name or (time_as_frames and name == "t")):
            continue
        shown = repr(name) if said.lower() == name else f"{said!r} ({name})"
        raise DataFormatError(
            source,
            f"the header names column {index + 1} {shown}, but it is read as {column!r} "
            f"(columns {','.join(columns)}){hint}",
            number,
        )


def is_number(token: str) -> bool:
    """Whether ``float`` reads ``token`` (``nan`` and ``inf`` included)."""
    try:
        float(token)
    except ValueError:
        return False
    return True


def parse_numbers_fast(text: str, width: int) -> tuple[np.ndarray, np.ndarray] | None:
    """NumPy's parser over the whole file, when every line is numbers (no header, no blank or
    comment lines, at least ``width`` columns); None otherwise."""
    if may_have_empty_field(text) or may_have_decimal_commas(text):
        return None  # NumPy would misread these: the slow path names the line
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file: the slow path says so in one line
            values = np.loadtxt(
                io.StringIO(text.replace(",", " ")), ndmin=2, usecols=range(width), comments=None
            )
    except (ValueError, IndexError):
        return None
    if len(values) != text.count("\n") + (not text.endswith("\n")):
        return None  # blank lines were skipped: line numbers would be off
    return values, np.arange(1, len(values) + 1)


def split_fields(source: Path, line: str, number: int) -> list[str]:
    """The fields of line ``number`` of ``source``, an empty string for each empty field; []
    for a blank line, a comment or a line of commas only. A line written with decimal commas
    is refused here, once for every reader: split at its commas, it would shift every column."""
    text = line.strip().rstrip(",").strip()
    if not text or text.startswith("#"):
        return []
    if "," in text:
        decimal = _decimal_comma_error(source, text, number)
        if decimal is not None:
            raise decimal
    return _SEPARATOR.split(text)


def empty_field_error(
    source: Path, fields: Sequence[str], text: str, line: int
) -> DataFormatError | None:
    """The error for an empty field among ``fields`` (the used columns of line number
    ``line``, whose ``text`` it quotes), if any."""
    if "" not in fields:
        return None
    return DataFormatError(source, f"an empty field in {text.strip()[:60]!r}", line)


def _decimal_comma_error(source: Path, text: str, line: int) -> DataFormatError | None:
    """The error for a line written with decimal commas (``0\t1\t0,5\t1,25``), if it is one:
    fields separated by whitespace, one of them a number with a comma for its point, none with
    a point. Read as separators, its commas would silently shift every column."""
    tokens = text.split()
    if len(tokens) < 2 or any("." in token for token in tokens):
        return None
    if not any(_DECIMAL_COMMA.fullmatch(token) for token in tokens):
        return None
    why = f"decimal commas in {text.strip()[:60]!r}? write numbers with a decimal point"
    return DataFormatError(source, why, line)


def may_have_decimal_commas(text: str) -> bool:
    """Whether some line of ``text`` may be written with decimal commas (a quick whole-file
    test: a comma between digits and whitespace between fields)."""
    return _DIGIT_COMMA_DIGIT.search(text) is not None and _BLANK_INSIDE.search(text) is not None


def may_have_empty_field(text: str) -> bool:
    """Whether some line of ``text`` may have an empty field (or trailing commas): a quick
    whole-file test for parsers that would merge it, such as NumPy's."""
    return _EMPTY_INSIDE.search(text) is not None or _EMPTY_FIRST.search("\n" + text) is not None


def refuse_bad_numbers(
    source: Path,
    values: np.ndarray,
    lines: np.ndarray,
    names: Mapping[int, str],
    whole: Sequence[int] = (),
) -> None:
    """Refuse, naming ``source`` and the line, the first row (in file order) with a value of a
    named column that is not finite, then the first with a value of a ``whole`` column that
    is not a whole number or is too large to count exactly.

    Args:
        values: (R, C) the numbers read, rows in file order.
        lines: (R,) the file line (or row number) of every row.
        names: column index -> the name to print, for every column to check.
        whole: the indices of columns that hold whole numbers (frames, ids).
    """
    columns = list(names)
    finite = np.isfinite(values[:, columns])  # (R, len(names))
    if not finite.all():
        row, at = _first(~finite)
        raise DataFormatError(source, f"{names[columns[at]]} is not finite", int(lines[row]))
    if not whole:
        return
    kept = values[:, list(whole)]  # (R, len(whole))
    fractional = kept != np.round(kept)
    if fractional.any():
        row, at = _first(fractional)
        why = f"{names[whole[at]]} must be a whole number, not {kept[row, at]:g}"
        raise DataFormatError(source, why, int(lines[row]))
    too_large = np.abs(kept) > MAX_WHOLE_NUMBER
    if too_large.any():
        row, at = _first(too_large)
        name = names[whole[at]]
        why = f"{name} {kept[row, at]:.3g} is out of range (|{name}| <= 2**53)"
        raise DataFormatError(source, why, int(lines[row]))


def refuse_duplicate_times(
    path: Path, ids: np.ndarray, time_s: np.ndarray, lines: np.ndarray
) -> None:
    """Refuse two rows of one person at one time: (R,) ids, seconds and file lines, sorted
    by (id, time)."""
    same = np.flatnonzero((ids[1:] == ids[:-1]) & (time_s[1:] == time_s[:-1]))
    if same.size:
        first, second = sorted((int(lines[same[0]]), int(lines[same[0] + 1])))
        raise DataFormatError(
            path, f"two rows for pedestrian {ids[same[0]]} at one time (also line {first})", second
        )


def _first(mask: np.ndarray) -> tuple[int, int]:
    """(row, column) of the first True of an (R, C) mask in row-major order."""
    row = int(np.flatnonzero(mask.any(axis=1))[0])
    return row, int(np.flatnonzero(mask[row])[0])


def ranges_to_indices(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenate ``arange(start, start + count)`` for every pair, vectorised."""
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.cumsum(counts) - counts  # where every range begins in the output
    return np.repeat(starts - offsets, counts) + np.arange(total)
