"""``grouptron data``: fetch and inspect the ETH/UCY benchmark."""

from __future__ import annotations

import argparse
import json

from grouptron.cli.common import data_settings
from grouptron.cli.options import int_list, parse_splits
from grouptron.data.dataset import load_part
from grouptron.data.download import fetch_dataset
from grouptron.data.locate import resolve_data_dir
from grouptron.data.subsets import UNIV_N_DEFINITIONS, UnivN, univ_n_mask


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
