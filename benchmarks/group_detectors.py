"""The time of one step's scene-wide groups, distance rule against learned detector, in a crowd.

Usage:
    python benchmarks/group_detectors.py [--people 300] [--repeats 30]

``--people`` walkers (pairs and threes among singles, 1.2 m/s, random headings) spread at the
density of a busy station (about 1 person per 3 m^2), 8 observed steps of 0.4 s; prints the
median and 90th percentile time of ``groups_at_step`` under ``DETECTION_GROUPS`` (the distance
rule with its size limit) and ``LEARNED_GROUPS`` (the shipped detector; one step alone, so
without its memory of pairs), one thread.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from grouptron.config import DataConfig
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.scene import build_scene
from grouptron.groups.learned import load_classifier
from grouptron.groups.scene import groups_at_step
from grouptron.presets import DETECTION_GROUPS, LEARNED_GROUPS


def crowd(people: int, seed: int = 0) -> np.ndarray:
    """(R, 4) ``frame id x y`` rows of ``people`` walkers over 8 steps (10 frames each)."""
    rng = np.random.default_rng(seed)
    side = np.sqrt(3.0 * people)  # metres: about 3 m^2 a person
    leaders = rng.uniform(0, side, size=(people, 2))
    follow = rng.random(people) < 0.4  # walks beside the one before
    heading = rng.uniform(0, 2 * np.pi, people)
    for k in np.flatnonzero(follow[1:]) + 1:
        leaders[k] = leaders[k - 1] + rng.normal(0, 0.3, 2) + [0.0, 0.7]
        heading[k] = heading[k - 1]
    velocity = 1.2 * np.stack([np.cos(heading), np.sin(heading)], 1)
    rows = [
        (10 * step, pid, *(leaders[pid] + velocity[pid] * 0.4 * step + rng.normal(0, 0.03, 2)))
        for step in range(8)
        for pid in range(people)
    ]
    return np.array(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--people", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=30)
    args = parser.parse_args()
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "crowd.txt"
        np.savetxt(path, crowd(args.people), fmt="%.4f")
        scene = build_scene(read_tracks(path), DataConfig(derivatives="backward"))
    load_classifier()  # read once, as a live session does
    for name, rule in (("distance rule", DETECTION_GROUPS), ("learned", LEARNED_GROUPS)):
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            found = groups_at_step(scene, rule, 7)
            times.append(1000 * (time.perf_counter() - start))
        assert found is not None
        sizes = np.bincount(found.labels)
        print(f"{name}: {args.people} people, median {np.median(times):.2f} ms, 90th "
              f"percentile {np.percentile(times, 90):.2f} ms; {int((sizes > 1).sum())} groups "
              f"of 2+, the largest {sizes.max()}")  # fmt: skip


if __name__ == "__main__":
    main()
