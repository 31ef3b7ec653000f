"""Shared pieces of the command line: the help formatter, the error-raising parser, option
groups used by several commands and argument types."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

import torch

from grouptron.constants import DT_S, FRAMES_PER_STEP, SPLITS
from grouptron.data.reader import TrackTable
from grouptron.data.recording import (
    DEFAULT_COLUMNS,
    UNITS_M,
    RecordingFormat,
    parse_columns,
    read_table,
)
from grouptron.data.spelling import FLAGS
from grouptron.devices import available_device
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import MODES
from grouptron.geometry import DERIVATIVE_SCHEMES

log = logging.getLogger("grouptron")
EXIT_USAGE = 2
REPORT_CHECKPOINTS = "checkpoints"
CURVES = "curves.png"


class Formatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples' line breaks and notes a default once: appended where an option has
    a real default its help does not already state (never "(default: None)")."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        missing = default is None or default is False or default is argparse.SUPPRESS
        unstated = missing or "default" in text.lower()
        if unstated or action.option_strings == [] or action.nargs == 0:
            return text
        return f"{text} (default: %(default)s)"


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        raise GrouptronError(message)


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--threads", type=positive_int, default=2, help="CPU threads for the computation"
    )


def add_device_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--device",
        type=device_type,
        default="cpu",
        help="where the network runs: cpu, cuda, cuda:1 or mps (one clear error where absent)",
    )


def add_gap_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--on-gap",
        choices=("split", "error"),
        default="split",
        help="a track that misses steps in the middle: split it into two tracks (with a "
        "warning) or stop with an error",
    )


def add_data_options(
    parser: argparse.ArgumentParser,
    derivatives: bool = True,
    cache_help: str = "rebuild samples instead of using the cache",
) -> None:
    parser.add_argument(
        "--data-dir",
        help="ETH/UCY folder (default: $GROUPTRON_DATA, else ~/.cache/grouptron/eth_ucy)",
    )
    if derivatives:
        parser.add_argument(
            "--derivatives",
            choices=DERIVATIVE_SCHEMES,
            help="velocity/acceleration scheme: 'central' (the papers' protocol, looks one step "
            "ahead; the default) or 'backward' (causal); a checkpoint brings its own",
        )
    add_gap_option(parser)
    parser.add_argument("--no-cache", action="store_true", help=cache_help)


def int_at_least(value: str, lowest: int) -> int:
    try:
        number = int(value)
    except ValueError:
        number = lowest - 1
    if number < lowest:
        wanted = "a positive integer" if lowest == 1 else f"an integer >= {lowest}"
        raise argparse.ArgumentTypeError(f"expected {wanted}, got {value!r}")
    return number


def float_at_least(value: str, lowest: float, *, strictly: bool) -> float:
    try:
        number = float(value)
    except ValueError:
        number = float("nan")
    if not (number > lowest if strictly else number >= lowest) or number == float("inf"):
        wanted = f"a number {'>' if strictly else '>='} {lowest:g}"
        raise argparse.ArgumentTypeError(f"expected {wanted}, got {value!r}")
    return number


def positive_float(value: str) -> float:
    return float_at_least(value, 0.0, strictly=True)


def non_negative_float(value: str) -> float:
    return float_at_least(value, 0.0, strictly=False)


def positive_int(value: str) -> int:
    return int_at_least(value, 1)


def non_negative_int(value: str) -> int:
    return int_at_least(value, 0)


def device_type(value: str) -> torch.device:
    """A torch device that exists here (one line, not a traceback, when it does not)."""
    try:
        return available_device(value)
    except GrouptronError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_splits(value: str) -> list[str]:
    if value == "all":
        return list(SPLITS)
    if value not in SPLITS:
        raise GrouptronError(f"unknown split {value!r}; choose from {', '.join(SPLITS)} or all")
    return [value]


def int_list(value: str) -> list[int]:
    try:
        numbers = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise GrouptronError(f"expected comma-separated integers, got {value!r}") from None
    if any(n < 1 for n in numbers):
        raise GrouptronError(f"expected positive integers, got {value!r}")
    return numbers


def eval_modes(value: str) -> tuple[str, ...]:
    if value == "all":
        return MODES
    modes = tuple(v.strip() for v in value.split(",") if v.strip())
    unknown = [m for m in modes if m not in MODES]
    if unknown or not modes:
        raise GrouptronError(
            f"unknown mode {', '.join(unknown) or value!r}; choose from {', '.join(MODES)} or all"
        )
    return tuple(dict.fromkeys(modes))  # a mode named twice is scored once


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars only on a terminal and without --quiet: a log file gets no carriage
    returns."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def add_recording_options(parser: argparse.ArgumentParser) -> None:
    """How a recording of one's own is laid out (any columns, frame rate, time base, units)."""
    parser.add_argument(
        "--columns",
        help="the columns of the files, in order, e.g. frame,id,x,y or id,frame,x,y,z or "
        "t,id,x,y: id, x, y and one time column, 'frame' (with --fps) or 't' (seconds, e.g. "
        "Unix time); other names (z, -) and columns past the named ones are ignored "
        "(default: frame,id,x,y, exactly four columns)",
    )
    parser.add_argument(
        "--fps",
        type=float,
        help="frames per second of a frame column (default: the ETH/UCY convention, 10 frames "
        "per 0.4 s step)",
    )
    parser.add_argument("--units", choices=tuple(UNITS_M), default="m", help="units of x and y")
    parser.add_argument(
        "--max-gap",
        type=float,
        help="seconds without an observation after which a track is split; shorter gaps are "
        f"bridged by linear interpolation on the 0.4 s resampling grid (default: "
        f"{RecordingFormat().max_gap_s} for recordings in other layouts; an ETH/UCY-style file "
        "has its gaps split unless this is given)",
    )
    parser.add_argument(
        "--no-speed-check",
        action="store_true",
        help="read files whose median walking speed is above 3 m/s (refused otherwise: a sign "
        "of wrong --units or --fps)",
    )


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
    fmt = recording_format(args, frames_per_step)
    return read_table(Path(args.tracks), fmt, frames_per_step, args.on_gap)


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
