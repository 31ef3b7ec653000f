"""Detected groups against human labels on the four labelled ETH/UCY recordings.

Usage:
    python benchmarks/group_labels.py --labels-dir DIR [--data-dir DIR]
    python benchmarks/group_labels.py --labels-dir DIR --sweep [--every 5]
                                      [--max-group-sizes 0,4,5,6,8]

DIR holds eth/, hotel/, zara1/, zara2/ with a groups.txt each (ids as in the benchmark files).
Every linkage and distance is scored with both scopes under the paper's C(N) rule; prints
Markdown tables (pairwise F1, precision, recall and Dice per recording, and the means used to
choose the defaults). ``--sweep`` scores the threshold rule instead, per-ego scope, over
linkages, cut heights, velocity weights and (single linkage) largest group sizes (0: none) on
every ``--every``-th step, each recording held out in turn, then the best one and C(N) again on
every step.
"""

from __future__ import annotations

import argparse
from itertools import product

import numpy as np

from grouptron.config import GroupConfig
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.groups.clustering import LINKAGES
from grouptron.groups.distances import DISTANCE_KINDS
from grouptron.groups.scene import LABELLED_RECORDINGS, labelled_recordings, score_against_labels

RECORDINGS = LABELLED_RECORDINGS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels-dir", required=True)
    parser.add_argument("--data-dir")
    parser.add_argument("--sweep", action="store_true", help="the threshold rule's grid")
    parser.add_argument("--every", type=int, default=5, help="sweep every k-th step")
    parser.add_argument(
        "--max-group-sizes", default="0", help="largest groups swept with single linkage (0: none)"
    )
    args = parser.parse_args()
    scenes, labels = labelled_recordings(args.labels_dir, resolve_data_dir(args.data_dir))
    if args.sweep:
        sizes = [int(n) or None for n in args.max_group_sizes.split(",")]
        sweep(scenes, labels, args.every, sizes)
        return
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


def per_ego_means(scenes: dict, labels: dict, config: GroupConfig, every: int) -> list[float]:
    """Per-recording per-ego pair F1, then the means of F1, precision and recall."""
    scores = [score_against_labels(scenes[n], labels[n], config, every=every)["per_ego"]
              for n in RECORDINGS]  # fmt: skip
    f1 = [s["pair_f1"] for s in scores]
    return [*f1, *(float(np.mean([s[k] for s in scores]))
                   for k in ("pair_f1", "pair_precision", "pair_recall"))]  # fmt: skip


def leave_one_out(grid: list[tuple[GroupConfig, list[float]]]) -> None:
    """Each recording held out in turn: the rule with the best mean F1 on the other three,
    and its F1 on the held-out one (an honest estimate of choosing on four recordings)."""
    print("\n### leave one recording out\n")
    print("| held out | chosen on the other three | their mean F1 | held-out F1 |")
    print("|---|---|---|---|")
    held = []
    for i, name in enumerate(RECORDINGS):

        def others(entry: tuple[GroupConfig, list[float]], i: int = i) -> float:
            return float(np.mean([f for j, f in enumerate(entry[1]) if j != i]))

        config, f1 = max(grid, key=others)
        held.append(f1[i])
        rule = f"{config.linkage}, {config.max_distance_m} m, {config.velocity_weight_s} s"
        rule += f", at most {config.max_group_size}" if config.max_group_size else ""
        print(f"| {name} | {rule} | {others((config, f1)):.3f} | {f1[i]:.3f} |")
    print(f"| mean | | | {np.mean(held):.3f} |")


def sweep(scenes: dict, labels: dict, every: int, sizes: list[int | None]) -> None:
    """The threshold rule's grid (every ``every``-th step), then the best and C(N) on all."""
    print(f"\n### threshold rule, scope `per_ego`, every {every}th step\n")
    print("| linkage | cut m | velocity weight s | largest group | "
          + " | ".join(f"{n} F1" for n in RECORDINGS)
          + " | mean F1 | mean precision | mean recall |")  # fmt: skip
    print("|---|---|---|---|" + "---|" * (len(RECORDINGS) + 3))
    best: tuple[float, GroupConfig] | None = None
    grid: list[tuple[GroupConfig, list[float]]] = []
    for linkage in LINKAGES:
        for weight in (0.0, 1.0, 2.0, 3.0, 4.0):
            for cut, size in product((1.0, 1.25, 1.5, 1.75, 2.0, 2.5), sizes):
                if size is not None and linkage != "single":
                    continue  # only single linkage chains
                config = GroupConfig(linkage=linkage, max_distance_m=cut,
                                     velocity_weight_s=weight, max_group_size=size)  # fmt: skip
                values = per_ego_means(scenes, labels, config, every)
                grid.append((config, values[: len(RECORDINGS)]))
                print(f"| {linkage} | {cut} | {weight} | {size or '-'} | "
                      + " | ".join(f"{v:.3f}" for v in values) + " |", flush=True)  # fmt: skip
                if best is None or values[len(RECORDINGS)] > best[0]:
                    best = (values[len(RECORDINGS)], config)
    assert best is not None
    leave_one_out(grid)
    print("\n### every step\n")
    for name, config in (("best of the grid", best[1]), ("C(N), complete", GroupConfig())):
        values = per_ego_means(scenes, labels, config, 1)
        print(f"| {name}: {config.linkage}, {config.max_distance_m}, {config.velocity_weight_s} | "
              + " | ".join(f"{v:.3f}" for v in values) + " |")  # fmt: skip


if __name__ == "__main__":
    main()
