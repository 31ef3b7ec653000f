"""Where the learned group detector loses a held-out recording: standing pairs or walking
ones, and whether a longer window or the memory of pairs helps.

Usage:
    python campaign/group_detector_diagnosis.py --labels-dir ../shared/data/groups
        [--data-dir DIR] [--held-out zara2] [--history 8,16,24,40] [--standers]

The classifier is trained on the other three labelled recordings (every 2nd step, as
``campaign/group_detector.py``) and scored scene-wide on every step of the held-out one. For
each window length (steps of 0.4 s): links of the pairs within 3 m where both stand (the faster
slower than ``WALKING_PACE`` of the crowd's pace) and where both walk, counted against the
labels without the memory; G-MITRE F1 without the memory, with it, and without it but with the
labels put in place of the classifier on the standing pairs or on the walking pairs (what
getting each right would be worth). ``--standers`` instead counts, per recording, the people
who stand for most of their track, how many of them are in a labelled group, how many walked
in, and how long they stood.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.prepare.scene import Scene
from grouptron.groups.labels import partition_from_labels
from grouptron.groups.learned import fit_classifier, linked_groups, near_pairs_now
from grouptron.groups.pair_features import FEATURES, pair_features
from grouptron.groups.pair_memory import WALKING_PACE, PairMemory, pair_keys
from grouptron.groups.partition_scores import PartitionCounts
from grouptron.groups.scene import LABELLED_RECORDINGS, labelled_recordings, position_grid
from grouptron.presets import LEARNED_GROUPS

RECORDINGS = LABELLED_RECORDINGS
SLOWER, FASTER = FEATURES.index("speed_low"), FEATURES.index("speed_high")


@dataclass(frozen=True)
class Step:
    """One step's near pairs: (P, 2) indices into the step's people, (P, F) features, (P,)
    whether the labels join them, (P,) keys for the memory; (N,) the labelled partition."""

    pairs: np.ndarray
    features: np.ndarray
    together: np.ndarray
    keys: np.ndarray
    truth: np.ndarray


def steps_of(scene: Scene, labels: dict[int, int], history: int, every: int) -> list[Step]:
    """The near pairs of every ``every``-th step with two or more people."""
    pad = history - 1
    pos, present = position_grid(scene, pad)
    found = []
    for step in range(0, scene.num_steps, every):  # one batch of pairs per step
        tracks = np.flatnonzero(present[:, step + pad])
        if len(tracks) < 2:
            continue
        window = slice(step, step + pad + 1)
        pairs = near_pairs_now(pos[tracks, step + pad])
        truth = partition_from_labels(scene.ped_id[tracks], labels)
        features = pair_features(pos[tracks, window], present[tracks, window], pairs, scene.dt_s)
        together = truth[pairs[:, 0]] == truth[pairs[:, 1]]
        keys = pair_keys(scene.ped_id[tracks], pairs)
        found.append(Step(pairs, features, together, keys, truth))
    return found


def gmitre_f1(steps: list[Step], probability: Callable[[Step], np.ndarray]) -> float:
    """Scene-wide G-MITRE F1 of the groups linked from each step's probabilities."""
    counts = PartitionCounts()
    for step in steps:  # in order: ``probability`` may remember
        n = len(step.truth)
        distances = np.full((n, n), np.inf)
        np.fill_diagonal(distances, 0.0)
        i, j = step.pairs[:, 0], step.pairs[:, 1]
        distances[i, j] = distances[j, i] = 1.0 - probability(step)
        threshold = LEARNED_GROUPS.max_distance_m
        assert threshold is not None
        counts.add(linked_groups(distances, threshold, LEARNED_GROUPS.max_group_size), step.truth)
    return counts.summary()["gmitre_f1"]


def remembered(memory: PairMemory, step: Step, probability: np.ndarray) -> np.ndarray:
    """The probabilities ``memory`` carries for the step's pairs (``pair_memory``)."""
    return memory.step(step.keys, probability, step.features[:, SLOWER], step.features[:, FASTER])


def diagnose(train: list[list[Step]], held: list[Step]) -> str:
    """One Markdown row's cells: standing and walking links, then four G-MITRE F1s."""
    features = np.concatenate([s.features for steps in train for s in steps])
    together = np.concatenate([s.together for steps in train for s in steps])
    classifier = fit_classifier(features, together)
    p = {id(s): classifier.probabilities(s.features) for s in held}
    stand = {id(s): s.features[:, FASTER] < WALKING_PACE for s in held}
    walk = {id(s): s.features[:, SLOWER] >= WALKING_PACE for s in held}
    cells = []
    for kind in (stand, walk):
        linked = sum(int(((p[id(s)] > 0.5) & s.together & kind[id(s)]).sum()) for s in held)
        pairs = sum(int((s.together & kind[id(s)]).sum()) for s in held)
        strangers = sum(int(((p[id(s)] > 0.5) & ~s.together & kind[id(s)]).sum()) for s in held)
        cells.append(f"{linked} of {pairs} ({strangers} strangers linked)")
    memory = PairMemory()
    scores = [
        gmitre_f1(held, lambda s: p[id(s)]),
        gmitre_f1(held, lambda s: remembered(memory, s, p[id(s)])),
        gmitre_f1(held, lambda s: np.where(stand[id(s)], s.together, p[id(s)])),
        gmitre_f1(held, lambda s: np.where(walk[id(s)], s.together, p[id(s)])),
    ]
    return " | ".join(cells + [f"{f:.3f}" for f in scores])


def standers(scene: Scene, labels: dict[int, int]) -> str:
    """People who stand (slower than 0.3 m/s) at most of their steps: how many, how many in a
    labelled group, how many walked at their first steps, their median time in view."""
    pos, present = position_grid(scene, 0)
    moved = np.linalg.norm(np.diff(pos, axis=1), axis=-1) / scene.dt_s  # (A, S - 1)
    seen = present[:, 1:] & present[:, :-1]
    standing = (moved < 0.3) & seen
    mostly = standing.sum(axis=1) > 0.5 * np.maximum(seen.sum(axis=1), 1)
    group = partition_from_labels(scene.ped_id, labels)
    in_group = (np.bincount(group)[group] > 1) & mostly
    first = np.argmax(seen, axis=1)  # (A,) their first step with a speed
    walked_in = mostly & ~standing[np.arange(len(first)), first]
    view_s = float(np.median(present.sum(axis=1)[mostly])) * scene.dt_s if mostly.any() else 0.0
    return (f"{int(mostly.sum())} mostly standing, {int(in_group.sum())} in a labelled group, "
            f"{int(walked_in.sum())} walked in; median {view_s:.0f} s in view")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels-dir", required=True)
    parser.add_argument("--data-dir")
    parser.add_argument("--held-out", choices=tuple(RECORDINGS), default="zara2")
    parser.add_argument("--history", default="8,16,24,40", help="window lengths, steps")
    parser.add_argument("--standers", action="store_true", help="count the standers only")
    args = parser.parse_args()
    scenes, labels = labelled_recordings(args.labels_dir, resolve_data_dir(args.data_dir))
    if args.standers:
        for name in RECORDINGS:
            print(f"{name}: {standers(scenes[name], labels[name])}")
        return
    print("| window, s | standing companions linked | walking companions linked | G-MITRE F1 "
          "| with the memory | labels on standing pairs | labels on walking pairs |\n"
          "|---|---|---|---|---|---|---|")  # fmt: skip
    for history in (int(h) for h in args.history.split(",")):
        train = [steps_of(scenes[n], labels[n], history, 2) for n in RECORDINGS
                 if n != args.held_out]  # fmt: skip
        held = steps_of(scenes[args.held_out], labels[args.held_out], history, 1)
        print(f"| {history * 0.4:.1f} | {diagnose(train, held)} |", flush=True)


if __name__ == "__main__":
    main()
