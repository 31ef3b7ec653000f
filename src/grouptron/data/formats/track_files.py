"""Tracks and how to read them, whatever they are: an ETH/UCY-style ``frame id x y`` file
read as it is, a recording in a layout of its own (resampled to 0.4 s steps), TrajNet++
``.ndjson``, or a topic of a ROS 2 bag (``.mcap``). Every command that reads ``--tracks`` and
``load_tracks`` describe them as a :class:`TrackSource`, and :data:`READERS`, keyed by the
file's suffix, is the one place that picks a reader.

    table, bag = read_track_file(TrackSource("corridor.txt", columns="t,id,x,y", units="cm"))
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from grouptron.constants import DT_S, FRAMES_PER_STEP
from grouptron.data.formats.layout import DEFAULT_COLUMNS, RecordingFormat, parse_columns
from grouptron.data.formats.reader import GapPolicy, TrackTable
from grouptron.data.formats.recording import read_ndjson_recording, read_table, resampled
from grouptron.data.formats.ros_bag import BagFields, BagTracks, read_bag_table
from grouptron.data.formats.spelling import KEYWORDS, OptionSpelling
from grouptron.errors import GrouptronError


@dataclass(frozen=True)
class TrackSource:
    """Track files and how they are laid out (the recording options of the commands).

    Attributes:
        path: the file, as messages name it (several files read alike: :meth:`files`).
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
        odom_topic: a bag's ``nav_msgs/msg/Odometry`` topic: tracks in its child frame
            (``base_link``) are put into its frame (``odom``) at their stamps.
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
    odom_topic: str | None = None
    spelling: OptionSpelling = field(default=KEYWORDS, compare=False, repr=False)

    @property
    def is_bag(self) -> bool:
        """Whether the file is a ROS 2 bag (``.mcap``)."""
        return reader_of(self.path) is _read_bag

    @classmethod
    def from_format(cls, path: str | Path, fmt: RecordingFormat) -> TrackSource:
        """``path`` read as a parsed layout says (a dataset description's ``[format]``)."""
        if fmt.as_is:
            return cls(path, check_speed=fmt.check_speed, spelling=fmt.spelling)
        return cls(
            path,
            columns=",".join(fmt.columns),
            fps=fmt.fps,
            units=fmt.units,
            max_gap_s=fmt.max_gap_s,
            check_speed=fmt.check_speed,
            spelling=fmt.spelling,
        )

    def of(self, path: str | Path) -> TrackSource:
        """Another file read the same way."""
        return replace(self, path=path)

    def files(self, paths: Iterable[str | Path]) -> tuple[TrackSource, ...]:
        """Each of ``paths`` read the same way."""
        return tuple(self.of(path) for path in paths)

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


Reader = Callable[["TrackSource", int, float], tuple[TrackTable, "BagTracks | None"]]
"""(source, frames per step of a file read as it is, seconds per step) -> the table, and a
bag's tracks."""


def read_track_file(
    source: TrackSource, frames_per_step: int = FRAMES_PER_STEP, dt_s: float = DT_S
) -> tuple[TrackTable, BagTracks | None]:
    """The file as a table, and what was read from a bag (None for a file of rows), by the
    reader of its suffix (:data:`READERS`).

    An ETH/UCY-style file is read as it is with ``source.frames_per_step`` (else
    ``frames_per_step``) frames per step; a layout of its own and TrajNet++ ``.ndjson`` are
    resampled to 0.4 s steps, in the file's own frame numbers where a step is a whole number
    of them, else in steps; a bag's ``topic`` is resampled from its first stamp."""
    return reader_of(source.path)(source, frames_per_step, dt_s)


def _read_rows(source: TrackSource, frames_per_step: int, dt_s: float) -> tuple[TrackTable, None]:
    """A text file of rows (or TrajNet++ ``.ndjson``, which brings its own layout)."""
    per_step = source.frames_per_step or frames_per_step
    fmt = source.recording_format(per_step)
    return read_table(Path(source.path), fmt, per_step, source.on_gap, dt_s), None


def _read_ndjson(source: TrackSource, frames_per_step: int, dt_s: float) -> tuple[TrackTable, None]:
    """A TrajNet++ ``.ndjson`` file (its own layout and frame rate), resampled."""
    fmt = source.recording_format(source.frames_per_step or frames_per_step)
    recording = read_ndjson_recording(Path(source.path), fmt)
    return resampled(recording, fmt, dt_s, source.on_gap), None


def _read_bag(
    source: TrackSource, frames_per_step: int, dt_s: float
) -> tuple[TrackTable, BagTracks]:
    """A topic of tracked people of a ROS 2 bag (resampled from its first stamp)."""
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
        odom_topic=source.odom_topic,
        max_gap_s=source.max_gap_s,
        check_speed=source.check_speed,
        on_gap=source.on_gap,
        dt_s=dt_s,
    )


READERS: dict[str, Reader] = {".mcap": _read_bag, ".ndjson": _read_ndjson, "": _read_rows}
"""The reader of each file suffix (``""``: any other, text rows): the one place that picks."""


def reader_of(path: str | Path) -> Reader:
    """The reader of ``path``'s suffix (text rows for one it does not name)."""
    return READERS.get(Path(path).suffix.lower(), READERS[""])


def load_tracks(source: TrackSource | str | Path, **layout: object) -> np.ndarray:
    """Tracks of any kind (a ROS 2 bag too) as (R, 4) rows ``frame, id, x, y`` for
    ``Predictor``: metres, resampled to 0.4 s steps, frames numbered 10 per step from the
    recording's first time (the ETH/UCY convention the checkpoints use). ``layout`` are the
    fields of :class:`TrackSource` (``columns`` also as a list of names).

        rows = load_tracks("corridor.txt", columns="id,frame,x,y,z", fps=16, units="cm")
        forecast = Predictor.from_checkpoint("grouptron-univ-backward").predict(rows)
    """
    if not isinstance(source, TrackSource):
        columns = layout.pop("columns", "frame,id,x,y")
        if not isinstance(columns, str):
            names = list(columns) if isinstance(columns, Iterable) else [columns]
            if not all(isinstance(name, str) for name in names):
                raise GrouptronError(
                    f"columns must be a string or a list of names, not {columns!r}"
                )
            columns = ",".join(str(name) for name in names)
        unknown = sorted(set(layout) - {f for f in TrackSource.__dataclass_fields__})
        if unknown:
            raise GrouptronError(f"load_tracks takes no {', '.join(unknown)}")
        source = TrackSource(source, columns=columns, **layout)  # type: ignore[arg-type]
    table, _ = read_track_file(source)
    frame = (table.step * FRAMES_PER_STEP).astype(np.float64)
    return np.column_stack([frame, table.ped_id.astype(np.float64), table.pos_m])


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


TrackFile = TrackSource
"""The older name of :class:`TrackSource`."""
