"""``grouptron data``: fetch and inspect the ETH/UCY benchmark (the counts:
:func:`grouptron.workflows.data.data_stats`)."""

from __future__ import annotations

import argparse

from grouptron.cli.common import data_settings
from grouptron.cli.options import int_list, parse_splits
from grouptron.data.datasets.download import fetch_dataset
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.workflows.data import data_stats


def cmd_data_fetch(args: argparse.Namespace) -> int:
    """``grouptron data fetch``: download missing or corrupt benchmark files, checking
    every file's checksum."""
    data_dir = resolve_data_dir(args.data_dir)
    report = fetch_dataset(data_dir, base_url=args.base_url, timeout_s=args.timeout)
    print(
        f"{data_dir}: {len(report.verified)} files verified, {len(report.downloaded)} "
        f"downloaded, {len(report.replaced)} corrupt files replaced"
    )
    return 0


def cmd_data_stats(args: argparse.Namespace) -> int:
    """``grouptron data stats``: scenes, tracks and samples per part of each split (UNIV-N
    counts for univ), as a table or JSON."""
    data_dir = resolve_data_dir(args.data_dir)
    config = data_settings(args)
    univ_n = int_list(args.univ_n)
    splits = parse_splits(args.split)
    stats = data_stats(
        splits, config, data_dir=data_dir, univ_n=univ_n, use_cache=not args.no_cache
    )
    print(stats.to_json() if args.format == "json" else stats.table())
    return 0
