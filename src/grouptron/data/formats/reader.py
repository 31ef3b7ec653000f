"""Reading and validating ``frame id x y`` track files.

Every problem is reported as a :class:`~grouptron.errors.DataFormatError` that names the file and,
where there is one, the line. The fast path parses the whole file with NumPy; only when that
fails is the file walked line by line to find the culprit.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from grouptron.constants import DT_S, FRAMES_PER_STEP
from grouptron.data.formats.fields import (
    empty_field_error,
    read_text_file,
    refuse_bad_numbers,
    refuse_header_disagreement,
    split_fields,
)
from grouptron.data.formats.glitches import repair_observations
from grouptron.data.formats.time_base import TimeBase, frames_time_base
from grouptron.errors import DataFormatError

log = logging.getLogger(__name__)

COLUMNS = ("frame", "id", "x", "y")
MAX_ABS_COORDINATE_M = 1e8
"""Larger coordinates are refused: projected (e.g. UTM) coordinates stay below 2e7 m, and far
larger ones overflow squared distances or lose every centimetre to float rounding."""
GapPolicy = Literal["split", "error"]


MAX_GRID_CELLS = 50_000_000
"""Bound on tracks x steps: per-step grids of the scene are dense (about 1 GB at the bound)."""


class OffGridError(DataFormatError):
    """A frame off the step grid: a file with a row every video frame, or other columns."""


@dataclass(frozen=True)
class TrackTable:
    """All observations of one file, one row per (pedestrian, step), sorted by (track, step).

    Attributes:
        path: the file read.
        first_frame: frame number of step 0.
        frames_per_step: frames between consecutive steps.
        ped_id: (R,) pedestrian id as written in the file.
        track: (R,) contiguous track index; a pedestrian whose track has gaps gets one track per
            gap-free piece.
        step: (R,) step index, ``(frame - first_frame) // frames_per_step``.
        pos_m: (R, 2) x, y in metres, in the file's world frame.
        time_base: how ``frame`` maps to the file's own time (None: an ETH/UCY-style file's
            frame numbers, ``frames_time_base``).
    """

    path: Path
    first_frame: int
    frames_per_step: int
    ped_id: np.ndarray
    track: np.ndarray
    step: np.ndarray
    pos_m: np.ndarray
    time_base: TimeBase | None = None

    @property
    def times(self) -> TimeBase:
        """The table's time base (an ETH/UCY-style file's when none was set)."""
        return self.time_base or frames_time_base(self.frames_per_step)

    @property
    def num_tracks(self) -> int:
        """Number of tracks (gap-free pieces); 0 for an empty table."""
        return int(self.track.max()) + 1 if self.track.size else 0

    @property
    def frame(self) -> np.ndarray:
        """(R,) frame number of every row."""
        return self.first_frame + self.step * self.frames_per_step


def _data_lines(path: Path, text: str) -> tuple[list[int], list[list[str]]]:
    """Line numbers and tokens of the non-blank lines, checking the column count."""
    numbers: list[int] = []
    rows: list[list[str]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        tokens = split_fields(path, line, number)
        if not tokens:
            continue  # blank or a comment
        if not rows and _is_header(tokens):
            hint = ": give the file's order with --columns"
            refuse_header_disagreement(path, tokens, COLUMNS, number, hint)
            continue  # a header line such as "frame id x y" (names, no numbers)
        if len(tokens) != len(COLUMNS):
            raise DataFormatError(
                path,
                f"expected 4 columns (frame id x y), found {len(tokens)}: {line.strip()[:60]!r}"
                + (
                    "; name them with --columns (extra ones are then ignored)"
                    if len(tokens) > 4
                    else ""
                ),
                number,
            )
        empty = empty_field_error(path, tokens, line, number)
        if empty is not None:
            raise empty
        numbers.append(number)
        rows.append(tokens)
    return numbers, rows


def _is_header(tokens: list[str]) -> bool:
    """A line of four column names: no token is a number."""
    if len(tokens) != len(COLUMNS):
        return False
    for token in tokens:
        try:
            float(token)
        except ValueError:
            continue
        return False
    return all(token.isidentifier() for token in tokens)


def _find_bad_value(path: Path, numbers: list[int], rows: list[list[str]]) -> DataFormatError:
    """Locate the first token that is not a finite number (slow path, only after a failure)."""
    for number, tokens in zip(numbers, rows, strict=True):
        for name, token in zip(COLUMNS, tokens, strict=True):
            try:
                value = float(token)
            except ValueError:
                why = f"{name} is not a number: {token[:40]!r}"
                if name == "id":
                    why += " (ids must be integers: map names such as 'ped_1' to numbers first)"
                return DataFormatError(path, why, number)
            if not math.isfinite(value):
                return DataFormatError(path, f"{name} is not finite: {token!r}", number)
    return DataFormatError(path, "could not parse the file")  # pragma: no cover


def _parse(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(R, 4) float64 values and (R,) line numbers of a file, all finite."""
    text = read_text_file(path)
    numbers, rows = _data_lines(path, text)
    if not rows:
        raise DataFormatError(path, "file is empty (no 'frame id x y' rows)")
    try:
        values = np.array(rows, dtype=np.float64)
    except ValueError:
        raise _find_bad_value(path, numbers, rows) from None
    if not np.isfinite(values).all():
        raise _find_bad_value(path, numbers, rows)
    return values, np.asarray(numbers)


def read_tracks(
    path: str | Path,
    frames_per_step: int = FRAMES_PER_STEP,
    on_gap: GapPolicy = "split",
    *,
    check_jumps: bool = False,
    dt_s: float = DT_S,
) -> TrackTable:
    """Read and validate a ``frame id x y`` file (tabs, spaces or commas; ``#`` comments).

    Args:
        path: the file.
        frames_per_step: frames between consecutive annotated steps (10 in ETH/UCY).
        on_gap: what to do with a track that misses steps in the middle: ``"split"`` it into
            separate tracks (with a warning) or raise an ``"error"``.
        check_jumps: repair impossible jumps (``data.formats.glitches``) with a warning that
            names each line; off for the benchmark's own files, which have none.

    Raises:
        DataFormatError: naming the file and line, for wrong column counts, non-numeric or
            non-finite values, non-integer frames or ids, duplicate (frame, id) rows, frames off
            the step grid, an empty or a missing file, and (with ``on_gap="error"``) gaps.
    """
    path = Path(path)
    if frames_per_step < 1:
        raise DataFormatError(path, f"frames per step must be >= 1, not {frames_per_step}")
    values, lines = _parse(path)
    return table_from_values(
        path, values, lines, frames_per_step, on_gap=on_gap, check_jumps=check_jumps, dt_s=dt_s
    )


def far_position(xy_m: np.ndarray) -> tuple[int, str] | None:
    """The first of (N, 2) finite positions beyond the range any scene has (wrong units, a
    sentinel value) and why, or None; NaN and inf are refused by other checks."""
    far = np.isfinite(xy_m) & (np.abs(xy_m) > MAX_ABS_COORDINATE_M)
    too_far = np.flatnonzero(far.any(axis=1))
    if not too_far.size:
        return None
    row = int(too_far[0])
    axis = int(np.abs(xy_m[row]).argmax())
    return row, (
        f"{'xy'[axis]} = {xy_m[row, axis]:.3g} m is out of range "
        f"(|x|, |y| <= {MAX_ABS_COORDINATE_M:.0e} m; positions are in metres)"
    )


def _check_range(path: Path, values: np.ndarray, lines: np.ndarray) -> None:
    found = far_position(values[:, 2:4])
    if found is not None:
        raise DataFormatError(path, found[1], int(lines[found[0]]))


def _grid_steps(
    path: Path, frame: np.ndarray, lines: np.ndarray, frames_per_step: int
) -> np.ndarray:
    """(R,) step of every row on the grid of ``frames_per_step`` frames from the first frame."""
    first_frame = int(frame.min())
    off_grid = np.flatnonzero((frame - first_frame) % frames_per_step)
    if off_grid.size:
        row = int(off_grid[0])
        raise OffGridError(
            path,
            f"frame {frame[row]} is not on the {frames_per_step}-frame grid that starts at frame "
            f"{first_frame} (every frame must be first_frame + a multiple of {frames_per_step})",
            int(lines[row]),
        )
    return (frame - first_frame) // frames_per_step


# One vectorised pass over every row, kept whole: each step reads the sorted arrays the
# step before it made, and cutting it up would pass a dozen arrays between the pieces.
def table_from_values(  # noqa: PLR0913 - the rows, then how to check them, keyword-only
    source: Path,
    values: np.ndarray,
    lines: np.ndarray,
    frames_per_step: int = FRAMES_PER_STEP,
    *,
    on_gap: GapPolicy = "split",
    warn_on_gap: bool = True,
    check_jumps: bool = False,
    pieces: np.ndarray | None = None,
    dt_s: float = DT_S,
) -> TrackTable:
    """Validate finite (R, 4) ``frame id x y`` values into a table; errors name ``source`` and
    the entry of ``lines`` (file line or row number) at fault. See :func:`read_tracks`.
    ``warn_on_gap=False`` splits gapped tracks silently (missed detections in live data);
    ``check_jumps`` repairs impossible jumps (steps ``dt_s`` apart), with a warning. (R,)
    ``pieces`` (a resampled recording's) keeps rows of one id in different pieces on different
    tracks."""
    if frames_per_step < 1 or len(values) == 0:
        why = "no 'frame id x y' rows" if len(values) == 0 else "frames per step must be >= 1"
        raise DataFormatError(source, f"{why}, not {frames_per_step}" if len(values) else why)
    path = source
    refuse_bad_numbers(path, values, lines, dict(enumerate(COLUMNS)), whole=(0, 1))
    _check_range(path, values, lines)
    frame = values[:, 0].astype(np.int64)
    ped_id = values[:, 1].astype(np.int64)
    pos_m = values[:, 2:4].copy()
    first_frame = int(frame.min())
    step = _grid_steps(path, frame, lines, frames_per_step)
    order = np.lexsort((step, ped_id))  # sort by id, then step
    ped_id, step, pos_m, lines = ped_id[order], step[order], pos_m[order], lines[order]
    same_ped = ped_id[1:] == ped_id[:-1]
    duplicate = np.flatnonzero(same_ped & (step[1:] == step[:-1]))
    if duplicate.size:
        first, second = sorted((int(lines[duplicate[0]]), int(lines[duplicate[0] + 1])))
        raise DataFormatError(
            path,
            f"duplicate row for pedestrian {ped_id[duplicate[0]]} at frame "
            f"{first_frame + step[duplicate[0]] * frames_per_step} (also on line {first})",
            second,
        )
    gap = same_ped & (step[1:] - step[:-1] > 1)
    if gap.any():
        where = int(np.flatnonzero(gap)[0])
        message = (
            f"pedestrian {ped_id[where]} has a gap between frames "
            f"{first_frame + step[where] * frames_per_step} and "
            f"{first_frame + step[where + 1] * frames_per_step}"
        )
        if on_gap == "error":
            raise DataFormatError(path, message, int(lines[where + 1]))
        if warn_on_gap:
            log.warning(
                "%s: %d track gap(s); split into tracks (first: %s)", path, gap.sum(), message
            )
    new_track = np.concatenate([[True], ~same_ped | gap])
    if pieces is not None:  # e.g. a lasting jump split before resampling
        piece = pieces[order]
        new_track[1:] |= piece[1:] != piece[:-1]
    if check_jumps:  # steps are dt_s apart whatever the frame rate (the benchmark's convention)
        keep, pos_m, split = repair_observations(path, ped_id, step * dt_s, pos_m, lines)
        new_track |= split
        # A dropped first row hands its track's start to the row after it.
        started = np.flatnonzero(~keep & new_track) + 1
        new_track[started[started < len(new_track)]] = True
        ped_id, step, lines, pos_m, new_track = (
            a[keep] for a in (ped_id, step, lines, pos_m, new_track)
        )
    track = np.cumsum(new_track) - 1
    return TrackTable(
        path=path,
        first_frame=first_frame,
        frames_per_step=frames_per_step,
        ped_id=ped_id,
        track=track,
        step=step,
        pos_m=pos_m,
    )
