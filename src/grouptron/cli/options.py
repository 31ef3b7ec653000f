"""The command line's parsers: the help formatter, the error-raising parser, option groups
used by several commands and argument types. Light on purpose: ``grouptron --help`` imports
this and the parsers, never PyTorch (the handlers import what they need when they run)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from grouptron.constants import (
    EVALUATION_MODES,
    MAX_GAP_S,
    MAX_REGION_Q,
    SPLITS,
    UNITS_M,
)
from grouptron.errors import GrouptronError
from grouptron.geometry import DERIVATIVE_SCHEMES
from grouptron.point_forecast import PointForecast, is_evaluation_mode

if TYPE_CHECKING:
    import torch

EXIT_USAGE = 2
REPORT_CHECKPOINTS = "checkpoints"


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
    """An argument parser whose usage errors print the usage and raise ``GrouptronError``
    (handled by the one error policy) instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        """Print the usage to stderr and raise ``GrouptronError`` with ``message`` (never exit)."""
        self.print_usage(sys.stderr)
        raise GrouptronError(message)


def add_threads_option(parser: argparse.ArgumentParser, default: int = 2, why: str = "") -> None:
    """Add ``--threads``: CPU threads for the computation (2 by default)."""
    parser.add_argument(
        "--threads",
        type=positive_int,
        default=default,
        help=f"CPU threads for the computation{why}",
    )


def add_device_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--device``: where the network runs (cpu by default)."""
    parser.add_argument(
        "--device",
        type=device_type,
        default="cpu",
        help="where the network runs: cpu, cuda, cuda:1 or mps (one clear error where absent)",
    )


def add_gap_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--on-gap``: split a track at a gap in the middle (the default) or stop."""
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
    derivatives_default: str = "central",
) -> None:
    """Add ``--data-dir``, ``--derivatives`` (where ``derivatives``), ``--on-gap`` and
    ``--no-cache`` (helped by ``cache_help``)."""
    parser.add_argument(
        "--data-dir",
        help="ETH/UCY folder (default: $GROUPTRON_DATA, else ~/.cache/grouptron/eth_ucy)",
    )
    if derivatives:
        parser.add_argument(
            "--derivatives",
            choices=DERIVATIVE_SCHEMES,
            help="velocity/acceleration scheme: 'backward' (causal) or 'central' (the papers' "
            f"protocol, looks one step ahead); {derivatives_default} by default, and a "
            "checkpoint brings its own",
        )
    add_gap_option(parser)
    parser.add_argument("--no-cache", action="store_true", help=cache_help)


def int_at_least(value: str, lowest: int) -> int:
    """``value`` as an integer of at least ``lowest``; an argparse error otherwise."""
    try:
        number = int(value)
    except ValueError:
        number = lowest - 1
    if number < lowest:
        wanted = "a positive integer" if lowest == 1 else f"an integer >= {lowest}"
        raise argparse.ArgumentTypeError(f"expected {wanted}, got {value!r}")
    return number


def float_at_least(value: str, lowest: float, *, strictly: bool) -> float:
    """``value`` as a finite number above ``lowest`` (``strictly``) or at least
    ``lowest``; an argparse error otherwise."""
    try:
        number = float(value)
    except ValueError:
        number = float("nan")
    if not (number > lowest if strictly else number >= lowest) or number == float("inf"):
        wanted = f"a number {'>' if strictly else '>='} {lowest:g}"
        raise argparse.ArgumentTypeError(f"expected {wanted}, got {value!r}")
    return number


def positive_float(value: str) -> float:
    """An argparse type: a finite number > 0."""
    return float_at_least(value, 0.0, strictly=True)


def non_negative_float(value: str) -> float:
    """An argparse type: a finite number >= 0."""
    return float_at_least(value, 0.0, strictly=False)


def positive_int(value: str) -> int:
    """An argparse type: an integer >= 1."""
    return int_at_least(value, 1)


def non_negative_int(value: str) -> int:
    """An argparse type: an integer >= 0."""
    return int_at_least(value, 0)


def device_type(value: str) -> torch.device:
    """A torch device that exists here (one line, not a traceback, when it does not)."""
    try:
        from grouptron.devices import available_device  # torch: only when a device is named

        return available_device(value)
    except GrouptronError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_splits(value: str) -> list[str]:
    """The splits ``value`` names: one ETH/UCY split, or every one for ``all``."""
    if value == "all":
        return list(SPLITS)
    if value not in SPLITS:
        raise GrouptronError(f"unknown split {value!r}; choose from {', '.join(SPLITS)} or all")
    return [value]


def metric_names(value: str) -> tuple[str, ...]:
    """Comma-separated metrics, each once, in the order given (resolved when the command runs:
    ``grouptron.evaluation.metrics.resolve_metric``)."""
    names = tuple(dict.fromkeys(v.strip() for v in value.split(",") if v.strip()))
    if not names:
        raise argparse.ArgumentTypeError(f"expected comma-separated metric names, got {value!r}")
    return names


METRICS_HELP = (
    "also score these metrics (comma-separated), beside ADE, FDE and the displacement error "
    "per step: miss-rate-Xm (the share of forecasts ending more than X m off; best-of-K: of "
    "samples whose K forecasts all do), the scene-level col-i and col-ii (the share of "
    "forecasts colliding with another forecast, or another person's true path, TrajNet++'s "
    "0.2 m), jade and jfde (the best of K chosen per scene and time step), module:name (a "
    "function (..., H, 2) forecasts, "
    "(..., H, 2) truths -> (...) scores, lower is better, or a Metric, of a module in the "
    "current folder or on PYTHONPATH), or the name of an installed package's "
    "grouptron.metrics entry point"
)
"""The help of ``--metrics`` (``evaluate``, ``report`` and ``compare``)."""


def int_list(value: str) -> list[int]:
    """Comma-separated positive integers, e.g. ``"1,5,10"`` -> ``[1, 5, 10]``."""
    try:
        numbers = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise GrouptronError(f"expected comma-separated integers, got {value!r}") from None
    if any(n < 1 for n in numbers):
        raise GrouptronError(f"expected positive integers, got {value!r}")
    return numbers


def region_probabilities(value: str) -> tuple[float, ...]:
    """Comma-separated probabilities of prediction regions, e.g. ``"0.5,0.9"``, each in
    (0, MAX_REGION_Q], each once, in the order given."""
    try:
        qs = [float(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise GrouptronError(
            f"--regions takes probabilities such as 0.5,0.9, not {value!r}"
        ) from None
    if not qs or any(not 0.0 < q <= MAX_REGION_Q for q in qs):
        raise GrouptronError(f"--regions probabilities must be in (0, {MAX_REGION_Q}]: {value!r}")
    return tuple(dict.fromkeys(qs))


def plot_region_probability(value: str) -> float | None:
    """One probability of a drawn region, or 0 for none."""
    if value.strip() in ("0", "none"):
        return None
    qs = region_probabilities(value)
    if len(qs) != 1:
        raise GrouptronError(f"--region takes one probability such as 0.9 (0: none): {value!r}")
    return qs[0]


def point_forecast_option(value: str) -> PointForecast:
    """A point forecast named on the command line: ml, ml-argmax, mean, ml-top10 or ml-topK."""
    try:
        return PointForecast.parse(value, option="--forecast")
    except GrouptronError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def calibration_option(value: str) -> str | bool:
    """``--calibration FILE``, or ``none`` for no calibration (False)."""
    return False if value == "none" else value


def forecast_option(value: str) -> PointForecast | str:
    """What ``predict`` writes: a point forecast (:func:`point_forecast_option`) or
    ``samples``."""
    return value if value == "samples" else point_forecast_option(value)


class OlderSpelling(argparse.Action):
    """An option's older spelling (``--mode`` of ``--forecast``): kept out of ``--help``, it
    sets the same value and says once on standard error what the option is called now."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: object) -> None:
        self.now_called = str(kwargs.pop("now_called"))
        kwargs.setdefault("help", argparse.SUPPRESS)
        super().__init__(option_strings, dest, **kwargs)  # type: ignore[arg-type]

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        """Store ``values`` under the option's name of today, saying so."""
        print(f"grouptron: {option_string} is now called {self.now_called}", file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_forecast_option(parser: argparse.ArgumentParser, help_text: str, *, samples: bool) -> None:
    """``--forecast`` (a point forecast, or ``samples`` where ``samples``) and its older
    spelling ``--mode``, both into ``args.forecast`` (None: the model's own)."""
    kind = forecast_option if samples else point_forecast_option
    choices = "ml,ml-argmax,mean,ml-top10,ml-topK" + (",samples" if samples else "")
    parser.add_argument("--forecast", type=kind, metavar="{" + choices + "}", help=help_text)
    parser.add_argument(
        "--mode", dest="forecast", type=kind, action=OlderSpelling, now_called="--forecast"
    )


def eval_modes(value: str) -> tuple[str, ...]:
    """Comma-separated evaluation modes (or ``all``), each once, in the order given."""
    if value == "all":
        return EVALUATION_MODES
    modes = tuple(v.strip() for v in value.split(",") if v.strip())
    unknown = [m for m in modes if not is_evaluation_mode(m)]
    if unknown or not modes:
        raise GrouptronError(
            f"unknown mode {', '.join(unknown) or value!r}; choose from "
            f"{', '.join(EVALUATION_MODES)}, ml-topK, best-of-K or all"
        )
    return tuple(dict.fromkeys(modes))  # a mode named twice is scored once


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
        f"{MAX_GAP_S} for recordings in other layouts; an ETH/UCY-style file "
        "has its gaps split unless this is given)",
    )
    parser.add_argument(
        "--topic",
        help="for a ROS 2 bag (.mcap): the topic of tracked people (people_msgs/msg/People, "
        "vision_msgs/msg/Detection3DArray or, with --ros-fields, any other; docs/robots.md)",
    )
    parser.add_argument(
        "--ros-fields",
        metavar="people=PATH,id=PATH,x=PATH,y=PATH",
        help="where another message type holds its people: dotted paths to the list, and in "
        "one person to the id and the x and y position",
    )
    parser.add_argument(
        "--odom-topic",
        help="for a ROS 2 bag: a nav_msgs/msg/Odometry topic; tracks in its child frame "
        "(base_link) are put into its frame (odom) at their stamps (docs/robots.md)",
    )
    parser.add_argument(
        "--fixed-frame",
        action="append",
        default=[],
        help="a frame id of your own that is fixed to the world (map, odom, world, earth and "
        "utm are known); tracks in any other frame are refused",
    )
    parser.add_argument(
        "--no-speed-check",
        action="store_true",
        help="read files whose median walking speed is above 3 m/s (refused otherwise: a sign "
        "of wrong --units or --fps), and leave jumps faster than anyone runs unrepaired "
        "(runners, vehicles)",
    )


def add_learning_options(
    parser: argparse.ArgumentParser, *, save_site: bool = False, scored: bool = False
) -> None:
    """``--learn`` and its knobs (predict, evaluate, ros2); ``--save-site`` and
    ``--scored-from`` where asked."""
    parser.add_argument(
        "--learn",
        action="store_true",
        help="learn the site online as a live session does: every 30 s of recording time the "
        "model is fine-tuned on the people seen walk so far, and the new weights are used only "
        "where they forecast better, beyond chance, on people they did not train on "
        "(docs/robots.md, 'Learning the site')",
    )
    parser.add_argument(
        "--learn-round-s",
        type=positive_float,
        default=30.0,
        help="seconds of recording time between learning rounds",
    )
    parser.add_argument(
        "--learn-steps",
        type=positive_int,
        default=60,
        help="optimiser steps of a learning round (batch 64; one thread)",
    )
    if save_site:
        parser.add_argument(
            "--save-site",
            metavar="FOLDER",
            help="with --learn: keep the weights in use at the end, and their card (site.json), "
            "in FOLDER; --checkpoint FOLDER loads them",
        )
    if scored:
        parser.add_argument(
            "--scored-from",
            type=float,
            default=0.5,
            help="with --learn: score the forecasts made from this share of each file's "
            "duration on (0.5: its later half); the learning runs from the start",
        )
