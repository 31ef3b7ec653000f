"""The parser of ``grouptron compare`` (its handler: ``grouptron.cli.compare``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import METRICS_HELP, Formatter, add_threads_option, metric_names
from grouptron.constants import SPLITS


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    compare = commands.add_parser(
        "compare",
        help="paired differences of two models on the same test samples, with intervals",
        description="Score A and B (each a checkpoint, a run folder, a shipped name, or "
        "forecast files made by any code: .csv in predict's layout or TrajNet++ .ndjson) on "
        "the same benchmark test samples and print their ADE/FDE and the paired difference "
        "B - A with its 95% interval over resampled time steps (below zero: B is closer to "
        "the truth). With several splits, the unweighted mean over them is added.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron compare trajectron++-eth-central grouptron-eth-central\n"
        "  grouptron compare runs/a runs/b --mode best-of-20\n"
        "  grouptron compare trajectron++-zara1-backward grouptron-zara1-backward --metrics col-i\n"
        "  grouptron compare grouptron-eth-backward theirs.csv --split eth",
    )
    compare.add_argument(
        "a",
        help="A: a checkpoint, run folder or shipped name, or forecast files (.csv/.ndjson; "
        "comma-separated, one per test recording, where a split has several)",
    )
    compare.add_argument("b", help="B: the same kinds as A")
    compare.add_argument(
        "--split",
        help=f"one or more of {', '.join(SPLITS)} (comma-separated) or all (default: the "
        "checkpoints' own split)",
    )
    compare.add_argument(
        "--mode",
        help="the evaluation mode of both (ml, ml-argmax, mean, ml-topK, best-of-K; default: "
        "each one's own point forecast, a file's ml or best-of-K of its samples)",
    )
    compare.add_argument(
        "--metrics", type=metric_names, default=(), metavar="NAME[,NAME...]", help=METRICS_HELP
    )
    compare.add_argument("--seed", type=int, default=0, help="seed of the sampling modes")
    compare.add_argument(
        "--format", choices=("table", "json"), default="table", help="output format"
    )
    compare.add_argument("--data-dir", help="the ETH/UCY folder (default: $GROUPTRON_DATA)")
    add_threads_option(compare)
    compare.set_defaults(handler="grouptron.cli.compare:cmd_compare")
