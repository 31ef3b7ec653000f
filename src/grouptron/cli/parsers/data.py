"""The parser of ``grouptron data`` (its handlers: ``grouptron.cli.data``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import Formatter, Parser, add_data_options
from grouptron.constants import SPLITS, UNIV_N_PAPER


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    data = commands.add_parser(
        "data",
        help="get and inspect the ETH/UCY benchmark",
        description="Get and inspect the ETH/UCY benchmark files.",
        formatter_class=Formatter,
        epilog="examples:\n  grouptron data fetch\n  grouptron data stats --split univ",
    )
    data_commands = data.add_subparsers(dest="data_command", metavar="ACTION", parser_class=Parser)

    fetch = data_commands.add_parser(
        "fetch",
        help="download the benchmark files and verify their checksums",
        description="Download the ETH/UCY files (Trajectron++ repository, fixed commit) into the "
        "data folder and verify every file against the SHA256 list shipped with grouptron. "
        "Files that already verify are kept; nothing half-written is ever left behind.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron data fetch\n"
        "  grouptron data fetch --data-dir ~/datasets/eth_ucy",
    )
    fetch.add_argument("--data-dir", help="target folder (default: $GROUPTRON_DATA or the cache)")
    fetch.add_argument(
        "--base-url", help="download from this URL prefix instead (or $GROUPTRON_DATA_URL)"
    )
    fetch.add_argument("--timeout", type=float, default=60.0, help="seconds per request")
    fetch.set_defaults(handler="grouptron.cli.data:cmd_data_fetch")

    stats = data_commands.add_parser(
        "stats",
        help="scenes, tracks and sample counts per split",
        description="Per split: scenes, tracks, training/validation/test samples, the most "
        "pedestrians in one step of the test recording(s), and for univ the UNIV-N subsets in "
        "both definitions: test samples at time steps with at least N predicted agents (test "
        "samples; the paper's Table II) and with at least N pedestrians present.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron data stats --split all\n"
        "  grouptron data stats --split univ --univ-n 30,40,50 --format json",
    )
    stats.add_argument("--split", default="all", help=f"one of {', '.join(SPLITS)} or all")
    stats.add_argument(
        "--univ-n",
        default=",".join(str(n) for n in UNIV_N_PAPER),
        help="comma-separated N for the UNIV-N counts",
    )
    stats.add_argument("--format", choices=("table", "json"), default="table", help="output format")
    add_data_options(stats)
    stats.set_defaults(handler="grouptron.cli.data:cmd_data_stats")
