"""Recordings in their own format: any column layout, frame rate, time base and units,
resampled onto the model's 0.4 s step.

A :class:`RecordingFormat` says how a file is laid out (``columns``, ``fps``, ``units``).
:func:`read_recording` reads it into times in seconds, ids and positions in metres;
:func:`resample` puts every track on a common grid of ``dt_s`` steps by linear interpolation
between the track's own observations (never extrapolated; a gap longer than ``max_gap_s``
splits the track); rows already on the grid are kept exactly. :func:`check_plausible` refuses
speeds no pedestrian walks, with a hint about units and frame rate; :func:`check_time_scale`
names the frame rate or time unit at which people walk at a usual pace, where a misread time
column leaves nothing to forecast."""

from __future__ import annotations

import dataclasses
import logging
import math
from pathlib import Path

import numpy as np

from grouptron.constants import (
    DT_S,
    FRAMES_PER_STEP,
    UNITS_M,
)
from grouptron.data.formats.fields import (
    MAX_WHOLE_NUMBER,
    empty_field_error,
    is_number,
    parse_numbers_fast,
    ranges_to_indices,
    read_text_file,
    refuse_bad_numbers,
    refuse_duplicate_times,
    refuse_header_disagreement,
    split_fields,
)
from grouptron.data.formats.glitches import repair_observations
from grouptron.data.formats.hints import (
    header_hint,
    layout_hint,
    not_a_number,
)
from grouptron.data.formats.layout import Recording, RecordingFormat
from grouptron.data.formats.ndjson import read_ndjson
from grouptron.data.formats.plausibility import (
    check_plausible,
    check_time_scale,
    recording_time_scale,
    time_hint,
)
from grouptron.data.formats.reader import (
    GapPolicy,
    OffGridError,
    TrackTable,
    read_tracks,
    table_from_values,
)
from grouptron.data.formats.time_base import resampled_time_base
from grouptron.errors import DataFormatError, GrouptronError

log = logging.getLogger(__name__)

ON_GRID_TOLERANCE = 1e-6
"""Observation times within this many steps of a grid point count as on the grid."""
MAX_SPAN_STEPS = 2**40
"""More 0.4 s steps than this (14,000 years) is a time column misread, not a recording; it
would also lose exactness in the float64 grid arithmetic."""


def _numbers(path: Path, fmt: RecordingFormat) -> tuple[np.ndarray, np.ndarray]:
    """(R, C) the numeric rows of a whitespace- or comma-separated file laid out as
    ``fmt.columns`` (a first line that is not numbers is a header, checked against them) and
    (R,) their line numbers."""
    columns, width = fmt.columns, len(fmt.columns)
    text = read_text_file(path)
    fast = parse_numbers_fast(text, width)
    if fast is not None:
        return fast
    # Slow path, only to name the line at fault (or to skip a header).
    rows: list[list[float]] = []
    lines: list[int] = []
    header_seen = False
    for number, raw in enumerate(text.splitlines(), start=1):
        fields = split_fields(path, raw, number)
        if not fields:
            continue  # blank or a comment
        if not rows and not header_seen and not any(is_number(f) for f in fields):
            order = f": give the file's order with {fmt.option('columns')}"
            hint = order + header_hint(raw, fmt.spelling)
            rated = fmt.fps is not None  # seconds may be read as frames at a given rate
            refuse_header_disagreement(path, fields, columns, number, hint, time_as_frames=rated)
            header_seen = True  # only the first line may be names
            continue
        if len(fields) < width:
            raise DataFormatError(
                path,
                f"{len(fields)} columns, but {width} column names were given: {raw.strip()[:60]!r}",
                number,
            )
        try:
            values = [float(f) for f in fields[:width]]  # columns past the named ones: ignored
        except ValueError:
            why = empty_field_error(path, fields[:width], raw, number)
            bad = why or DataFormatError(path, not_a_number(fields[:width], columns), number)
            raise bad from None
        rows.append(values)
        lines.append(number)
    if not rows:
        raise DataFormatError(path, "no rows of numbers")
    return np.asarray(rows, dtype=np.float64), np.asarray(lines)


def read_ndjson_recording(path: Path, fmt: RecordingFormat) -> Recording:
    """A TrajNet++ ``.ndjson`` file, which brings its own layout and frame rate (``fmt``: its
    units and checks); positions in metres, times in seconds."""
    rows, lines, seconds_per_frame = read_ndjson(Path(path))
    return Recording(
        Path(path),
        rows[:, 1].astype(np.int64),
        rows[:, 0] * seconds_per_frame,
        rows[:, 2:4] * UNITS_M[fmt.units],
        lines,
        seconds_per_frame,
        own_times=True,
    )


def read_recording(path: Path, fmt: RecordingFormat) -> Recording:
    """Read a file of rows laid out as ``fmt`` says; positions in metres, times in seconds."""
    values, lines = _numbers(Path(path), fmt)
    column = {name: fmt.columns.index(name) for name in ("id", "x", "y", fmt.time_column)}
    used = {i: name for name, i in column.items()}  # ignored columns may hold anything
    refuse_bad_numbers(Path(path), values, lines, used, whole=(column["id"],))
    ped_id = values[:, column["id"]]
    time = values[:, column[fmt.time_column]]
    time_s = time if fmt.time_column == "t" else time * fmt.seconds_per_frame
    scale = UNITS_M[fmt.units]
    pos_m = values[:, [column["x"], column["y"]]] * scale
    per_frame = fmt.seconds_per_frame if fmt.time_column == "frame" else None
    return Recording(Path(path), ped_id.astype(np.int64), time_s, pos_m, lines, per_frame)


# One vectorised pass over every row, kept whole: each step reads the sorted arrays the
# step before it made, and cutting it up would pass a dozen arrays between the pieces.
def resample(
    recording: Recording,
    fmt: RecordingFormat,
    dt_s: float = DT_S,
    on_gap: GapPolicy = "split",
    *,
    warn_on_gap: bool = True,
) -> TrackTable:
    """Every track on the grid ``t0 + k * dt_s`` (t0: the recording's first time), linearly
    interpolated between consecutive observations of the track that are at most
    ``fmt.max_gap_s`` apart; never extrapolated. Observations on the grid keep their values.

    Returns a table in the file's own frame numbers when a step is a whole number of its
    frames and the first frame is on it (ETH/UCY: 10, TrajNet: 12); else its "frames" are the
    grid steps (``first_frame`` 0, ``frames_per_step`` 1). ``on_gap="error"`` refuses a
    track with a gap longer than ``fmt.max_gap_s`` instead of splitting it; ``warn_on_gap``
    False splits it without a warning.
    """
    span_steps = (recording.time_s.max() - recording.time_s.min()) / dt_s
    if not span_steps < MAX_SPAN_STEPS:
        raise GrouptronError(
            f"{recording.path}: its times span {span_steps:.3g} steps of {dt_s} s; check the "
            f"time column (frame numbers with {fmt.option('fps')}, or 't' in seconds)"
            f"{time_hint(recording, fmt)}"
        )
    order = np.lexsort((recording.time_s, recording.ped_id))
    ids, time_s = recording.ped_id[order], recording.time_s[order]
    pos, lines = recording.pos_m[order], recording.line[order]
    refuse_duplicate_times(recording.path, ids, time_s, lines)
    split_before = np.zeros(len(ids), dtype=bool)
    if fmt.check_speed:  # impossible jumps repaired before they are interpolated onto the grid
        keep, pos, split_before = repair_observations(recording.path, ids, time_s, pos, lines)
        ids, time_s, pos, lines = ids[keep], time_s[keep], pos[keep], lines[keep]
        split_before = split_before[keep]
    steps = (time_s - time_s.min()) / dt_s  # (R,) time in grid steps
    snapped = np.round(steps)
    on_grid = np.abs(steps - snapped) < ON_GRID_TOLERANCE
    steps = np.where(on_grid, snapped, steps)
    # Segments between consecutive observations of one track, bridged when short enough.
    joined = (ids[1:] == ids[:-1]) & (np.diff(time_s) <= fmt.max_gap_s + 1e-9)
    split = np.flatnonzero((ids[1:] == ids[:-1]) & ~joined)
    if split.size and on_gap != "error" and warn_on_gap:  # as the ETH/UCY reader says it
        _warn_gaps(recording.path, fmt, ids[split], time_s[split + 1] - time_s[split], lines[split])
    joined &= ~split_before[1:]
    if on_gap == "error" and split.size:
        at = int(split[0])
        raise DataFormatError(
            recording.path,
            f"pedestrian {ids[at]} is not observed for {time_s[at + 1] - time_s[at]:.3g} s, "
            f"longer than {fmt.option('max_gap_s')} {fmt.max_gap_s:g} s",
            int(lines[at + 1]),
        )
    first = np.ceil(steps[:-1]).astype(np.int64)
    last = np.where(joined, np.ceil(steps[1:]) - 1, np.floor(steps[:-1])).astype(np.int64)
    counts = np.where(joined, np.maximum(last - first + 1, 0), 0)
    segment = np.repeat(np.arange(len(first)), counts)
    grid = ranges_to_indices(first, counts)  # (G,) grid step of every new row
    # The last observation of a piece ends no segment: add it when it is on the grid.
    ends = np.flatnonzero(np.append(~joined, True) & (steps == np.round(steps)))
    span = np.where(joined[segment], np.diff(steps)[segment], 1.0)
    weight = np.where(joined[segment], (grid - steps[:-1][segment]) / span, 0.0)[:, None]
    nxt = np.minimum(segment + 1, len(pos) - 1)
    new_pos = pos[segment] * (1 - weight) + pos[nxt] * weight
    all_step = np.concatenate([grid, steps[ends].astype(np.int64)])
    all_pos = np.concatenate([new_pos, pos[ends]])
    all_id = np.concatenate([ids[segment], ids[ends]])
    all_line = np.concatenate([lines[segment], lines[ends]])
    piece = np.concatenate([[0], np.cumsum(~joined)])  # (R,) piece of every observation
    all_piece = np.concatenate([piece[segment], piece[ends]])
    keep = np.unique(np.column_stack([all_piece, all_step]), axis=0, return_index=True)[1]
    first_frame, per_step = _frame_base(recording, dt_s)
    frame = first_frame + all_step[keep] * per_step
    values = np.column_stack([frame, all_id[keep], all_pos[keep]])
    table = table_from_values(
        recording.path, values, all_line[keep], per_step, warn_on_gap=False, pieces=all_piece[keep]
    )
    per_frame = recording.seconds_per_frame  # own frames: as _frame_base keeps them
    one_per_step = per_frame is not None and math.isclose(per_frame, dt_s)
    own = (first_frame, per_step) != (0, 1) or one_per_step
    base = resampled_time_base(float(time_s.min()), per_frame, own, dt_s)  # the grid's origin
    return dataclasses.replace(table, time_base=base)


def _warn_gaps(
    path: Path, fmt: RecordingFormat, ids: np.ndarray, seconds: np.ndarray, lines: np.ndarray
) -> None:
    """One warning for the (G,) gaps longer than ``fmt.max_gap_s`` that split tracks."""
    log.warning(
        "%s: %d track gap(s) longer than %s %g s; split into tracks (first: pedestrian %s is "
        "not observed for %.3g s after line %d)",
        *(path, len(ids), fmt.option("max_gap_s"), fmt.max_gap_s),
        *(ids[0], seconds[0], lines[0]),
    )


def _frame_base(recording: Recording, dt_s: float) -> tuple[int, int]:
    """(first frame, frames per step) of the output: the file's own frames when a step is a
    whole number of them (ETH/UCY: 10, TrajNet: 12) and they count exactly (not Unix time in
    nanoseconds), else grid steps (0, 1)."""
    per_frame = recording.seconds_per_frame
    if per_frame is None or np.abs(recording.time_s).max() / per_frame > MAX_WHOLE_NUMBER:
        return 0, 1
    per_step = dt_s / per_frame
    if abs(per_step - round(per_step)) > ON_GRID_TOLERANCE or round(per_step) < 1:
        return 0, 1
    return round(float(recording.time_s.min()) / per_frame), round(per_step)


def read_table(
    path: Path,
    fmt: RecordingFormat,
    frames_per_step: int = FRAMES_PER_STEP,
    on_gap: GapPolicy = "split",
    dt_s: float = DT_S,
) -> TrackTable:
    """A track file as a table: with ``fmt.as_is`` an ETH/UCY-style file as it is
    (``frames_per_step`` frames per step, gaps split with a warning or refused per
    ``on_gap``), else resampled to ``dt_s`` steps."""
    if not fmt.as_is:
        return read_resampled(Path(path), fmt, dt_s, on_gap)
    try:
        table = read_tracks(path, frames_per_step, on_gap, check_jumps=fmt.check_speed, dt_s=dt_s)
    except DataFormatError as exc:
        hint = layout_hint(Path(path), fmt.spelling, off_grid=isinstance(exc, OffGridError))
        if not hint:
            raise
        raise DataFormatError(exc.path, exc.message + hint, exc.line) from None
    if fmt.check_speed:
        # Steps of an ETH/UCY-style file are dt_s apart, whatever its frames per step.
        lines = np.zeros_like(table.step)  # not needed: the check names no line
        time_s, per_frame = table.step * dt_s, dt_s / frames_per_step
        check_plausible(
            Recording(table.path, table.ped_id, time_s, table.pos_m, lines, per_frame), fmt
        )
    return table


def read_resampled(
    path: Path, fmt: RecordingFormat, dt_s: float = DT_S, on_gap: GapPolicy = "split"
) -> TrackTable:
    """Read, check and resample a file of rows (:func:`resampled`)."""
    return resampled(read_recording(path, fmt), fmt, dt_s, on_gap)


def resampled(
    recording: Recording, fmt: RecordingFormat, dt_s: float = DT_S, on_gap: GapPolicy = "split"
) -> TrackTable:
    """Check a recording read in any format and resample it to ``dt_s`` steps."""
    if fmt.check_speed:
        scale = recording_time_scale(recording)
        check_plausible(recording, fmt, scale)
        check_time_scale(recording, fmt, scale, dt_s)
    return resample(recording, fmt, dt_s, on_gap)
