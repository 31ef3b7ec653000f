"""Preprocessing speed: cold build of all five splits (train, val, test) and a warm cache load.

Usage:
    python benchmarks/preprocessing.py [--data-dir DIR] [--repeats 3]

Each cold run uses a fresh, empty cache folder, so it reads, validates, derives, finds
neighbours and writes the cache from scratch. Medians are printed as a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import DataConfig
from grouptron.constants import PARTS, SPLITS
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.locate import resolve_data_dir


def load_everything(data_dir: Path, config: DataConfig) -> int:
    return sum(
        len(load_part(data_dir, split, part, config).samples) for split in SPLITS for part in PARTS
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    data_dir = resolve_data_dir(args.data_dir)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cpus")
    print(
        "| scheme | samples | cold, all 5 splits (s) | warm cache load (s) "
        "| CV eval, 5 splits (s) |"
    )
    print("|---|---|---|---|---|")
    for scheme in ("central", "backward"):
        config = DataConfig(derivatives=scheme)
        cold, warm, cv = [], [], []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as cache:
                os.environ["GROUPTRON_CACHE"] = cache
                start = time.perf_counter()
                count = load_everything(data_dir, config)
                cold.append(time.perf_counter() - start)
                start = time.perf_counter()
                load_everything(data_dir, config)
                warm.append(time.perf_counter() - start)
                start = time.perf_counter()
                for split in SPLITS:
                    test = load_part(data_dir, split, "test", config).samples
                    pred = constant_velocity(test.hist_rel_m.astype(np.float64), 12)
                    np.linalg.norm(pred - test.fut_rel_m, axis=-1).mean()
                cv.append(time.perf_counter() - start)
        print(
            f"| {scheme} | {count} | {statistics.median(cold):.2f} | "
            f"{statistics.median(warm):.2f} | {statistics.median(cv):.2f} |"
        )


if __name__ == "__main__":
    main()
