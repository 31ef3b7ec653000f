"""Shared pieces of the command handlers: reading a ``--tracks`` file as its options describe
it, progress bars, the look-ahead warning. (The parsers' shared pieces are in ``options``.)"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from grouptron.config import DataConfig
from grouptron.constants import DT_S, FRAMES_PER_STEP
from grouptron.data.reader import TrackTable
from grouptron.data.recording import (
    DEFAULT_COLUMNS,
    RecordingFormat,
    parse_columns,
    read_table,
)
from grouptron.data.ros_bag import BagFields, BagTracks, read_bag_table
from grouptron.data.spelling import FLAGS
from grouptron.errors import GrouptronError

log = logging.getLogger("grouptron")


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars only on a terminal and without --quiet: a log file gets no carriage
    returns."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def own_layout(args: argparse.Namespace) -> bool:
    """Whether the recording options describe a layout of its own rather than an ETH/UCY-style
    file read as it is (a ``--max-gap`` of its own asks for gaps to be bridged by resampling;
    naming ``--columns``, even the default order, lets columns past them be ignored)."""
    return (
        args.columns is not None
        or args.fps is not None
        or args.units != RecordingFormat().units
        or args.max_gap is not None
    )


def read_track_table(args: argparse.Namespace, frames_per_step: int) -> TrackTable:
    """The ``--tracks`` file: an ETH/UCY-style file as it is (``--frames-per-step``,
    ``--on-gap``), or a recording in its own layout (``--columns``, ``--fps``, ``--units``;
    TrajNet++ ``.ndjson``) resampled to 0.4 s steps, in its own frame numbers where a step is a
    whole number of them, else in steps."""
    if Path(args.tracks).suffix == ".mcap":
        return read_bag_tracks(args)[0]
    fmt = recording_format(args, frames_per_step)
    return read_table(Path(args.tracks), fmt, frames_per_step, args.on_gap)


def read_bag_tracks(args: argparse.Namespace) -> tuple[TrackTable, BagTracks]:
    """The ``--topic`` of a ``--tracks`` ROS 2 bag, resampled to 0.4 s steps from its first
    stamp, and what was read from it."""
    if not getattr(args, "topic", None):
        raise GrouptronError(
            f"{args.tracks} is a ROS 2 bag: name the topic of tracked people (--topic)"
        )
    fields = BagFields.parse(args.ros_fields) if args.ros_fields else None
    return read_bag_table(
        Path(args.tracks),
        args.topic,
        fields,
        tuple(args.fixed_frame),
        max_gap_s=args.max_gap,
        check_speed=not args.no_speed_check,
        on_gap=args.on_gap,
    )


def recording_format(
    args: argparse.Namespace, frames_per_step: int = FRAMES_PER_STEP
) -> RecordingFormat:
    """The layout the recording options describe; without ``--fps`` a ``frame`` column has
    ``frames_per_step`` frames per 0.4 s step (ETH/UCY: 10, i.e. 25 fps)."""
    columns = DEFAULT_COLUMNS if args.columns is None else parse_columns(args.columns, FLAGS)
    given_per_step = getattr(args, "frames_per_step", None)
    if args.fps is not None and given_per_step not in (None, FRAMES_PER_STEP):
        raise GrouptronError(
            "--fps and --frames-per-step both set the frame rate: give one (--frames-per-step "
            "is for a 'frame id x y' file read as it is)"
        )
    fps = args.fps
    if fps is None and frames_per_step != FRAMES_PER_STEP and "t" not in columns:
        fps = frames_per_step / DT_S
    return RecordingFormat(
        columns=columns,
        fps=fps,
        units=args.units,
        max_gap_s=RecordingFormat().max_gap_s if args.max_gap is None else args.max_gap,
        check_speed=not args.no_speed_check,
        as_is=not own_layout(args),
        spelling=FLAGS,
    )


def data_settings(args: argparse.Namespace) -> DataConfig:
    """The data settings of a command without a checkpoint (``data stats``, constant velocity):
    ``--derivatives`` if given, else the papers' (``DataConfig``'s default), and ``--on-gap``."""
    chosen = {"derivatives": args.derivatives} if args.derivatives else {}
    return DataConfig(on_gap=args.on_gap, **chosen)


def warn_look_ahead(name: str, derivatives: str) -> None:
    """Say once per command that a central checkpoint reads positions after the forecast time
    (docs/recordings.md, "Look-ahead")."""
    if derivatives == "central":
        log.warning(
            "%s was trained with central derivatives: each forecast reads the position one "
            "step after the forecast time, which live data does not have; use a backward "
            "checkpoint for causal forecasts",
            name,
        )
