"""Detected groups against human labels on the four labelled ETH/UCY recordings.

Usage:
    python benchmarks/group_labels.py --labels-dir DIR [--data-dir DIR]

DIR holds eth/, hotel/, zara1/, zara2/ with a groups.txt each (ids as in the benchmark files).
Every linkage and distance is scored with both scopes; prints Markdown tables (pairwise F1,
precision, recall and Dice per recording, and the means used to choose the defaults).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.locate import resolve_data_dir
from grouptron.data.reader import read_tracks
from grouptron.data.scene import build_scene
from grouptron.groups.clustering import LINKAGES
from grouptron.groups.distances import DISTANCE_KINDS
from grouptron.groups.labels import read_group_labels
from grouptron.groups.scene import score_against_labels

RECORDINGS = {"eth": "biwi_eth", "hotel": "biwi_hotel", "zara1": "crowds_zara01",
              "zara2": "crowds_zara02"}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels-dir", required=True)
    parser.add_argument("--data-dir")
    args = parser.parse_args()
    data_dir = resolve_data_dir(args.data_dir)
    scenes = {
        name: build_scene(read_tracks(data_dir / "all_data" / f"{file}.txt"), DataConfig())
        for name, file in RECORDINGS.items()
    }
    labels = {name: read_group_labels(Path(args.labels_dir) / name / "groups.txt")
              for name in RECORDINGS}  # fmt: skip
    for scope in ("per_ego", "scene"):
        print(f"\n### scope `{scope}`\n")
        print("| linkage | distance | " + " | ".join(f"{n} F1 / Dice" for n in RECORDINGS)
              + " | mean F1 | mean Dice | mean precision | mean recall |")  # fmt: skip
        print("|---|---|" + "---|" * (len(RECORDINGS) + 4))
        for linkage in LINKAGES:
            for distance in DISTANCE_KINDS:
                config = GroupConfig(linkage=linkage, distance=distance)
                scores = [score_against_labels(scenes[n], labels[n], config)[scope]
                          for n in RECORDINGS]  # fmt: skip
                cells = " | ".join(f"{s['pair_f1']:.3f} / {s['dice']:.3f}" for s in scores)
                means = [np.mean([s[k] for s in scores])
                         for k in ("pair_f1", "dice", "pair_precision", "pair_recall")]  # fmt: skip
                print(f"| {linkage} | {distance} | {cells} | "
                      + " | ".join(f"{m:.3f}" for m in means) + " |")  # fmt: skip


if __name__ == "__main__":
    main()
