"""``grouptron data``: fetch and inspect the ETH/UCY benchmark."""

from __future__ import annotations

import argparse
import json

from grouptron.cli.common import (
    Formatter,
    Parser,
    add_data_options,
    int_list,
    parse_splits,
)
from grouptron.config import (
    DataConfig,
)
from grouptron.constants import SPLITS, UNIV_N_PAPER
from grouptron.data.dataset import load_part
from grouptron.data.download import fetch_dataset
from grouptron.data.locate import resolve_data_dir
from grouptron.data.subsets import UNIV_N_DEFINITIONS, UnivN, univ_n_mask


def cmd_data_fetch(args: argparse.Namespace) -> int:
    data_dir = resolve_data_dir(args.data_dir)
    report = fetch_dataset(data_dir, base_url=args.base_url, timeout_s=args.timeout)
    print(
        f"{data_dir}: {len(report.verified)} files verified, {len(report.downloaded)} "
        f"downloaded, {len(report.replaced)} corrupt files replaced"
    )
    return 0


def cmd_data_stats(args: argparse.Namespace) -> int:
    data_dir = resolve_data_dir(args.data_dir)
    config = DataConfig(derivatives=args.derivatives or "central", on_gap=args.on_gap)
    univ_n = int_list(args.univ_n)
    stats: dict[str, dict[str, object]] = {}
    for split in parse_splits(args.split):
        parts = {
            part: load_part(data_dir, split, part, config, use_cache=not args.no_cache)
            for part in ("train", "val", "test")
        }
        scenes = [s for p in parts.values() for s in p.scenes]
        entry: dict[str, object] = {
            "scenes": len(scenes),
            "tracks": sum(s.num_tracks for s in scenes),
            "train_samples": len(parts["train"].samples),
            "val_samples": len(parts["val"].samples),
            "test_samples": len(parts["test"].samples),
            "test_max_pedestrians_per_step": max(s.max_present for s in parts["test"].scenes),
        }
        if split == "univ":
            test = parts["test"].samples
            entry["univ_n"] = {
                definition: {
                    str(n): int(univ_n_mask(test, UnivN(n, definition)).sum()) for n in univ_n
                }
                for definition in UNIV_N_DEFINITIONS
            }
        stats[split] = entry
    if args.format == "json":
        print(json.dumps(stats, indent=2))
        return 0
    header = (
        f"{'split':<6} {'scenes':>6} {'tracks':>7} {'train':>8} {'val':>7} {'test':>7} "
        f"{'max peds/step (test)':>21}"
    )
    print(f"ETH/UCY samples ({config.derivatives} derivatives) from {data_dir}")
    print(header)
    print("-" * len(header))
    for split, e in stats.items():
        print(
            f"{split:<6} {e['scenes']:>6} {e['tracks']:>7} {e['train_samples']:>8} "
            f"{e['val_samples']:>7} {e['test_samples']:>7} "
            f"{e['test_max_pedestrians_per_step']:>21}"
        )
    if "univ" in stats:
        counts = stats["univ"]["univ_n"]
        assert isinstance(counts, dict)
        for definition, label in (
            ("predicted", "at steps with >= N predicted agents (the paper's)"),
            ("present", "at steps with >= N pedestrians present"),
        ):
            per_n = ", ".join(f"N={n}: {c}" for n, c in counts[definition].items())
            print(f"UNIV-N test samples {label}: {per_n}")
    return 0


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
    fetch.set_defaults(handler=cmd_data_fetch)

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
    stats.set_defaults(handler=cmd_data_stats)
