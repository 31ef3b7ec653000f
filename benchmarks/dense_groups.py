"""Group sizes of detection rules in dense crowds (no labels there): does a rule chain a crowd
into one group?

Usage:
    python benchmarks/dense_groups.py [--rules single,1.5,2.0 average,1.75,4.0 ...]
                                      [--ood-dir ../shared/data/ood] [--crowds-dir ...]

Scene-wide groups (as ``grouptron groups detect --detector distance`` and ``Forecast.group``
find them) at every 5th step of two dense HERMES corridor experiments of the out-of-domain
development set and of the first Grand Central file; prints, per rule and recording, the people
per step, the biggest group (mean over steps / largest), the mean size of groups of two or more,
and the share of those with at most 4 members (pedestrian groups have 2-4).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.formats.layout import RecordingFormat, parse_columns
from grouptron.data.formats.recording import read_resampled, read_table
from grouptron.data.prepare.scene import build_scene
from grouptron.groups.scene import groups_per_step

HERMES = RecordingFormat(columns=parse_columns("id,frame,x,y,z"), fps=16, units="cm")


def recordings(ood_dir: Path, crowds_dir: Path) -> dict[str, tuple[Path, RecordingFormat]]:
    corridor = ood_dir / "hermes_corridor_1d"
    return {
        "corridor uo-300": (corridor / "uo-300-300-300.txt", HERMES),
        "corridor uo-180": (corridor / "uo-180-180-180.txt", HERMES),
        "Grand Central gc_000": (crowds_dir / "gc" / "gc_000.txt", RecordingFormat(as_is=True)),
    }


def rule(text: str) -> GroupConfig:
    """``"single,1.5,2.0"``: linkage, cut in metres, velocity weight in seconds, and
    optionally the largest group (``"single,1.5,2.0,6"``)."""
    linkage, cut, weight, *size = text.split(",")
    return GroupConfig(
        linkage=linkage,  # type: ignore[arg-type]
        max_distance_m=float(cut),
        velocity_weight_s=float(weight),
        max_group_size=int(size[0]) if size else None,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rules",
        nargs="+",
        default=["single,1.5,2.0", "single,1.5,2.0,6", "single,1.5,2.0,4", "average,1.75,4.0"],
    )
    shared = Path(__file__).resolve().parents[2] / "shared" / "data"
    parser.add_argument("--ood-dir", type=Path, default=shared / "ood")
    parser.add_argument("--crowds-dir", type=Path, default=shared / "crowds")
    args = parser.parse_args()
    print("| rule | recording | people per step | biggest group, mean / max | mean size of "
          "groups of 2+ | share of those with 2-4 |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for text in args.rules:
        config = rule(text)
        for name, (path, fmt) in recordings(args.ood_dir, args.crowds_dir).items():
            table = read_table(path, fmt) if fmt.as_is else read_resampled(path, fmt)
            scene = build_scene(table, DataConfig(), name=name)
            biggest, people, sizes = [], [], []
            for found in groups_per_step(scene, config, every=5):
                counts = np.bincount(found.labels)
                biggest.append(int(counts.max()))
                people.append(len(found.labels))
                sizes += counts[counts >= 2].tolist()
            multi = np.asarray(sizes)
            print(f"| {text} | {name} | {np.mean(people):.0f} | {np.mean(biggest):.1f} / "
                  f"{max(biggest)} | {multi.mean():.2f} | {np.mean(multi <= 4):.2f} |",
                  flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
