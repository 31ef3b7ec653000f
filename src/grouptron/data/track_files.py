"""One track file and how to read it, whatever it is: an ETH/UCY-style ``frame id x y`` file
read as it is, a recording in a layout of its own (resampled to 0.4 s steps), TrajNet++
``.ndjson``, or a topic of a ROS 2 bag (``.mcap``). The commands that read ``--tracks``
(``predict``, ``plot``, ``calibrate``, ``groups``) describe it as a :class:`TrackFile`.

    table, bag = read_track_file(TrackFile("corridor.txt", columns="t,id,x,y", units="cm"))
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grouptron.constants import DT_S, FRAMES_PER_STEP
from grouptron.data.reader import GapPolicy, TrackTable
from grouptron.data.recording import DEFAULT_COLUMNS, RecordingFormat, parse_columns, read_table
from grouptron.data.ros_bag import BagFields, BagTracks, read_bag_table
from grouptron.data.spelling import KEYWORDS, OptionSpelling
from grouptron.errors import GrouptronError


@dataclass(frozen=True)
class TrackFile:
    """A track file and how it is laid out (the recording options of the commands).

    Attributes:
        path: the file, as messages name it.
        columns: its columns, comma-separated (``"t,id,x,y"``; :class:`RecordingFormat`);
            None: ``frame,id,x,y`` exactly.
        fps: frames per second of a ``frame`` column (None: 10 frames per 0.4 s step).
        units: of x and y: ``m``, ``cm`` or ``mm``.
        max_gap_s: seconds without an observation after which a track is split (None: 0.8 s
            for a layout of its own; an ETH/UCY-style file read as it is splits every gap).
        check_speed: refuse implausible walking speeds and repair jumps.
        on_gap: a track that misses steps in the middle: ``split`` (with a warning) or
            ``error``.
        frames_per_step: frames between steps of an ETH/UCY-style file (None: the reader's
            default, e.g. the checkpoint's).
        topic: a bag's topic of tracked people.
        bag_fields: where another message type holds its people,
            ``people=PATH,id=PATH,x=PATH,y=PATH`` (:class:`BagFields`).
        fixed_frames: frame ids of one's own fixed to the world.
        spelling: how messages name these options (the command line's flags, or keywords).
    """

    path: str | Path
    columns: str | None = None
    fps: float | None = None
    units: str = "m"
    max_gap_s: float | None = None
    check_speed: bool = True
    on_gap: GapPolicy = "split"
    frames_per_step: int | None = None
    topic: str | None = None
    bag_fields: str | None = None
    fixed_frames: tuple[str, ...] = ()
    spelling: OptionSpelling = field(default=KEYWORDS, compare=False, repr=False)

    @property
    def is_bag(self) -> bool:
        """Whether the file is a ROS 2 bag (``.mcap``)."""
        return Path(self.path).suffix == ".mcap"

    @property
    def as_is(self) -> bool:
        """Whether it is an ETH/UCY-style file read as it is rather than a layout of its own
        (a ``max_gap_s`` of its own asks for gaps to be bridged by resampling; naming
        ``columns``, even the default order, lets columns past them be ignored)."""
        return (
            self.columns is None
            and self.fps is None
            and self.units == RecordingFormat().units
            and self.max_gap_s is None
        )

    def recording_format(self, frames_per_step: int = FRAMES_PER_STEP) -> RecordingFormat:
        """The layout; without ``fps`` a ``frame`` column has ``frames_per_step`` frames per
        0.4 s step (ETH/UCY: 10, i.e. 25 fps)."""
        name = self.spelling.name
        columns = (
            DEFAULT_COLUMNS if self.columns is None else parse_columns(self.columns, self.spelling)
        )
        if self.fps is not None and self.frames_per_step not in (None, FRAMES_PER_STEP):
            raise GrouptronError(
                f"{name('fps')} and {name('frames_per_step')} both set the frame rate: give one "
                f"({name('frames_per_step')} is for a 'frame id x y' file read as it is)"
            )
        fps = self.fps
        if fps is None and frames_per_step != FRAMES_PER_STEP and "t" not in columns:
            fps = frames_per_step / DT_S
        return RecordingFormat(
            columns=columns,
            fps=fps,
            units=self.units,
            max_gap_s=RecordingFormat().max_gap_s if self.max_gap_s is None else self.max_gap_s,
            check_speed=self.check_speed,
            as_is=self.as_is,
            spelling=self.spelling,
        )


def read_track_file(
    source: TrackFile, frames_per_step: int = FRAMES_PER_STEP
) -> tuple[TrackTable, BagTracks | None]:
    """The file as a table, and what was read from a bag (None for a file of rows).

    An ETH/UCY-style file is read as it is with ``source.frames_per_step`` (else
    ``frames_per_step``) frames per step; a layout of its own and TrajNet++ ``.ndjson`` are
    resampled to 0.4 s steps, in the file's own frame numbers where a step is a whole number
    of them, else in steps; a bag's ``topic`` is resampled from its first stamp."""
    if source.is_bag:
        return _read_bag(source)
    per_step = source.frames_per_step or frames_per_step
    fmt = source.recording_format(per_step)
    return read_table(Path(source.path), fmt, per_step, source.on_gap), None


def _read_bag(source: TrackFile) -> tuple[TrackTable, BagTracks]:
    if not source.topic:
        raise GrouptronError(
            f"{source.path} is a ROS 2 bag: name the topic of tracked people "
            f"({source.spelling.name('topic')})"
        )
    fields = BagFields.parse(source.bag_fields) if source.bag_fields else None
    return read_bag_table(
        Path(source.path),
        source.topic,
        fields,
        source.fixed_frames,
        max_gap_s=source.max_gap_s,
        check_speed=source.check_speed,
        on_gap=source.on_gap,
    )


def table_rows(table: TrackTable) -> np.ndarray:
    """(R, 4) ``frame, id, x, y`` of a table (``Predictor``'s rows), each person's earlier
    tracks (split at a gap or a jump) under fresh ids, so that a predictor does not join them
    up again."""
    last_track = np.zeros(table.num_tracks, dtype=bool)
    ends = np.flatnonzero(np.append(table.ped_id[1:] != table.ped_id[:-1], True))
    last_track[table.track[ends]] = True  # rows are sorted by id, then step
    ids = table.ped_id.astype(np.float64)
    fresh = float(ids.max()) + 1 + table.track
    ids = np.where(last_track[table.track], ids, fresh)
    return np.column_stack([table.frame, ids, table.pos_m]).astype(np.float64)
