"""The learned group detector: chosen leave-one-recording-out on the four recordings with human
group labels, then trained on all four and shipped.

Usage:
    python campaign/group_detector.py --labels-dir ../shared/data/groups [--data-dir DIR]
                                      [--every 2] [--seed 0] [--no-ship] [--nested]

Each recording is held out in turn: the pair classifier (``grouptron.groups.learned``) is
trained on the pairs of the other three (every ``--every``-th step), then the held-out
recording is scored on every step beside the distance rule (``DETECTION_GROUPS``, chosen on all
four): G-MITRE F1 and pair F1 scene-wide, pair F1 per ego, exact-match F1. Nothing is tuned on
the held-out recording (the link threshold is ``LEARNED_LINK_PROBABILITY``; the detector
remembers each pair from step to step, ``grouptron.groups.pair_memory``). ``--seed`` seeds its
first network (the others the next seeds), to see how much the scores owe to the seeds.
``--nested`` instead asks what choosing the memory's weight on leave-one-out scores
costs: each recording held out in turn, the weight (no memory, 1, 0.3, 0.1) is chosen on the
other three alone (each held out from the other two), then scored on it. Prints a Markdown
table; then (unless ``--no-ship``) trains on all four and writes
``src/grouptron/groups/detector/best.safetensors`` (its card: README.md beside it).
"""

from __future__ import annotations

import argparse

import numpy as np

from grouptron.config import GroupConfig
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.prepare.scene import Scene
from grouptron.groups.learned import SHIPPED_DETECTOR, PairClassifier, fit_classifier
from grouptron.groups.pair_memory import MEMORY_WEIGHT
from grouptron.groups.scene import (
    LABELLED_RECORDINGS,
    labelled_pairs,
    labelled_recordings,
    score_against_labels,
)
from grouptron.presets import DETECTION_GROUPS, LEARNED_GROUPS

RECORDINGS = LABELLED_RECORDINGS
T_DANTE_GMITRE = {"eth": 0.66, "hotel": 0.54, "zara1": 0.84, "zara2": 0.87}
"""T-DANTE's G-MITRE F1 (5-fold cross-validation within each recording), read from its plots."""


MEMORY_CHOICES = (None, 1.0, 0.3, 0.1)
"""The memory's weights ``--nested`` chooses from (None: no memory)."""


def scores(scene: Scene, labels: dict[int, int], rule: GroupConfig, every: int,
           classifier: PairClassifier | None,
           memory_weight: float | None = MEMORY_WEIGHT) -> dict[str, float]:  # fmt: skip
    """G-MITRE F1, pair F1 (scene-wide and per ego) and exact-match F1 of one recording."""
    found = score_against_labels(
        scene, labels, rule, every=every, classifier=classifier, memory_weight=memory_weight
    )
    return {
        "gmitre_f1": found["scene"]["gmitre_f1"],
        "pair_f1": found["scene"]["pair_f1"],
        "per_ego_pair_f1": found["per_ego"]["pair_f1"],
        "exact_f1": found["scene"]["exact_f1"],
    }


def fit(
    names: list[str], data: dict[str, tuple[np.ndarray, np.ndarray]], seed: int
) -> PairClassifier:
    """The classifier trained on the pairs of ``names``."""
    features = np.concatenate([data[n][0] for n in names])
    together = np.concatenate([data[n][1] for n in names])
    return fit_classifier(features, together, seed=seed)


def nested(scenes: dict[str, Scene], labels: dict[str, dict[int, int]],
           data: dict[str, tuple[np.ndarray, np.ndarray]], seed: int) -> None:  # fmt: skip
    """Each recording held out in turn, the memory's weight chosen on the other three alone,
    then scored on it (prints a Markdown table)."""
    print("\n| held out | inner G-MITRE F1 by weight (none, 1, 0.3, 0.1) | chosen | G-MITRE F1 "
          "| pair F1 |\n|---|---|---|---|---|")  # fmt: skip
    for held in RECORDINGS:
        rest = [n for n in RECORDINGS if n != held]
        inner: dict[float | None, list[float]] = {w: [] for w in MEMORY_CHOICES}
        for check in rest:  # each of the other three held out from the other two
            classifier = fit([n for n in rest if n != check], data, seed)
            for weight in MEMORY_CHOICES:
                found = scores(scenes[check], labels[check], LEARNED_GROUPS, 1, classifier, weight)
                inner[weight].append(found["gmitre_f1"])
        means = {w: float(np.mean(v)) for w, v in inner.items()}
        chosen = max(MEMORY_CHOICES, key=lambda w: means[w])
        found = scores(scenes[held], labels[held], LEARNED_GROUPS, 1, fit(rest, data, seed), chosen)
        print(f"| {held} | {' / '.join(f'{means[w]:.3f}' for w in MEMORY_CHOICES)} | "
              f"{'none' if chosen is None else chosen} | {found['gmitre_f1']:.3f} | "
              f"{found['pair_f1']:.3f} |", flush=True)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels-dir", required=True)
    parser.add_argument("--data-dir")
    parser.add_argument("--every", type=int, default=2, help="training pairs of every k-th step")
    parser.add_argument("--seed", type=int, default=0, help="the first network's seed")
    parser.add_argument("--nested", action="store_true", help="choose the memory's weight "
                        "within each held-out fold instead (writes nothing)")  # fmt: skip
    parser.add_argument("--no-ship", action="store_true", help="do not write the shipped file")
    args = parser.parse_args()
    scenes, labels = labelled_recordings(args.labels_dir, resolve_data_dir(args.data_dir))
    data = {n: labelled_pairs(scenes[n], labels[n], every=args.every)[:2] for n in RECORDINGS}
    for name, (_, together) in data.items():
        print(f"{name}: {len(together)} pairs within 3 m, {int(together.sum())} together")
    if args.nested:
        nested(scenes, labels, data, args.seed)
        return
    print("\n| held out | detector | G-MITRE F1 | pair F1 | per-ego pair F1 | exact F1 "
          "| T-DANTE G-MITRE F1 |\n|---|---|---|---|---|---|---|")  # fmt: skip
    for held in RECORDINGS:
        classifier = fit([n for n in RECORDINGS if n != held], data, args.seed)
        for detector, rule, model in (
            ("learned", LEARNED_GROUPS, classifier),
            ("distance rule", DETECTION_GROUPS, None),
        ):
            s = scores(scenes[held], labels[held], rule, 1, model)
            print(f"| {held} | {detector} | {s['gmitre_f1']:.3f} | {s['pair_f1']:.3f} | "
                  f"{s['per_ego_pair_f1']:.3f} | {s['exact_f1']:.3f} | "
                  f"{T_DANTE_GMITRE[held]:.2f} |", flush=True)  # fmt: skip
    if args.no_ship:
        return
    shipped = fit(list(RECORDINGS), data, args.seed)
    about = {"recordings": list(RECORDINGS), "every": args.every, "seed": args.seed}
    shipped.save(SHIPPED_DETECTOR, about)
    print(f"\nwrote {SHIPPED_DETECTOR}: trained on the pairs of all four")


if __name__ == "__main__":
    main()
