"""The parser of ``grouptron adapt`` (its handler: ``grouptron.cli.adapt``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    Formatter,
    add_gap_option,
    add_recording_options,
    add_threads_option,
    positive_int,
)
from grouptron.constants import DEFAULT_CHECKPOINT


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add ``grouptron adapt``."""
    adapt = commands.add_parser(
        "adapt",
        help="fine-tune a checkpoint on the first minutes of a site's own recordings",
        description="Fine-tune a checkpoint (a fixed budget of optimiser steps, fp32, a fresh "
        "optimiser) on the first --minutes of a site's recordings, played one after the other "
        "in the order given, and, with --holdout-minutes, score the checkpoint before and after "
        "on the recordings' last minutes, which the adaptation never sees (a paired FDE "
        "difference with its 95% interval, constant velocity beside them). The two parts may "
        "not overlap. The adapted folder records which files and seconds it adapted on; "
        "evaluate warns when it is given them. docs/recordings.md, 'Site adaptation'.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron adapt --tracks monday.csv tuesday.csv --columns t,id,x,y --minutes 15 \\\n"
        "      --holdout-minutes 5 --out runs/lobby\n"
        "  grouptron predict --checkpoint runs/lobby/best.safetensors --tracks wednesday.csv \\\n"
        "      --columns t,id,x,y --out forecasts.csv",
    )
    adapt.add_argument(
        "--tracks", nargs="+", required=True, help="the site's recordings, in time order"
    )
    adapt.add_argument(
        "--minutes",
        type=float,
        default=5.0,
        help="the adaptation part: the first minutes (default 5)",
    )
    adapt.add_argument(
        "--holdout-minutes",
        type=float,
        default=0.0,
        help="the held-out part: the last minutes, scored before and after (default 0: none)",
    )
    adapt.add_argument(
        "--checkpoint",
        default=DEFAULT_CHECKPOINT,
        help="a .safetensors checkpoint or a shipped name (default: the model predict uses)",
    )
    adapt.add_argument("--out", default="runs/adapted", help="the adapted run's folder")
    adapt.add_argument(
        "--steps",
        type=positive_int,
        default=300,
        help="optimiser steps of the fine-tune (default 300)",
    )
    adapt.add_argument("--lr", type=float, default=3e-4, help="learning rate (default 3e-4)")
    adapt.add_argument("--seed", type=int, default=0, help="seed of the order (default 0)")
    adapt.add_argument("--quiet", action="store_true", help="no progress bars")
    add_gap_option(adapt)
    add_recording_options(adapt)
    add_threads_option(adapt)
    adapt.set_defaults(handler="grouptron.cli.adapt:cmd_adapt")
