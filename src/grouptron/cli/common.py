"""Shared pieces of the command handlers: the ``--tracks`` file as its options describe it,
progress bars, data settings. (The parsers' shared pieces are in ``options``.)"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from grouptron.config import DataConfig
from grouptron.data.formats.spelling import FLAGS
from grouptron.data.formats.track_files import TrackFile


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars only on a terminal and without --quiet: a log file gets no carriage
    returns."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def track_file(args: argparse.Namespace, path: str | Path | None = None) -> TrackFile:
    """The ``--tracks`` file as its recording options describe it (``--columns``, ``--fps``,
    ``--units``, ``--max-gap``, ``--no-speed-check``, ``--on-gap``, ``--frames-per-step``;
    a bag's ``--topic``, ``--ros-fields``, ``--fixed-frame``, ``--odom-topic``), its messages
    naming the flags;
    ``path`` instead of ``--tracks`` where that names several files."""
    return TrackFile(
        args.tracks if path is None else path,
        columns=args.columns,
        fps=args.fps,
        units=args.units,
        max_gap_s=args.max_gap,
        check_speed=not args.no_speed_check,
        on_gap=getattr(args, "on_gap", "split"),
        frames_per_step=getattr(args, "frames_per_step", None),
        topic=getattr(args, "topic", None),
        bag_fields=getattr(args, "ros_fields", None),
        fixed_frames=tuple(getattr(args, "fixed_frame", None) or ()),
        odom_topic=getattr(args, "odom_topic", None),
        spelling=FLAGS,
    )


def own_layout(args: argparse.Namespace) -> bool:
    """Whether the recording options describe a layout of its own rather than an ETH/UCY-style
    file read as it is (:attr:`TrackFile.as_is`)."""
    return not track_file(args, path="").as_is


def data_settings(args: argparse.Namespace) -> DataConfig:
    """The data settings of a command without a checkpoint (``data stats``, constant velocity):
    ``--derivatives`` if given, else the papers' (``DataConfig``'s default), and ``--on-gap``."""
    chosen = {"derivatives": args.derivatives} if args.derivatives else {}
    return DataConfig(on_gap=args.on_gap, **chosen)
