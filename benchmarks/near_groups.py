"""Groups at a step from near pairs only against the all-pairs clustering, on a recording.

Usage:
    python benchmarks/near_groups.py FILE [--every 1]

For every ``--every``-th step of a ``frame id x y`` file (10 frames per 0.4 s step; e.g. the
densest Grand Central file, ``gc_043.txt``), under the default model's rule (single linkage
at 1.5 m, velocities 2 s apart, no size cap): the scene-wide groups of ``groups_at_step`` (the
k-d tree and the bound per pair) and of all pairs, and each person's own grouping (the people
within 3 m, as the model reads them) from both distance matrices. Prints the steps compared,
the people and pairs measured, the time of each path, and every difference (none expected).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import PERCEPTION_RADIUS_M
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.scene import build_scene
from grouptron.groups import scene as groups_scene
from grouptron.groups.clustering import agglomerative_groups
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file")
    parser.add_argument("--every", type=int, default=1)
    args = parser.parse_args()
    rule = load_trained_model(resolve_checkpoint(DEFAULT_CHECKPOINT))[1].groups
    scene = build_scene(read_tracks(Path(args.file), 10), DataConfig(derivatives="backward"))
    pos, present = groups_scene.position_grid(scene, 7)
    steps = differences = egos = 0
    seconds = {"near pairs": 0.0, "all pairs": 0.0}
    busiest = 0
    for step in range(0, scene.num_steps, args.every):
        started = time.perf_counter()
        new = groups_scene._cluster_step(
            pos, present, step, 7, config=rule, dt_s=scene.dt_s, near_only=True
        )  # groups_at_step's path, on the grid made once
        seconds["near pairs"] += time.perf_counter() - started
        started = time.perf_counter()
        old = groups_scene._cluster_step(pos, present, step, 7, config=rule, dt_s=scene.dt_s)
        seconds["all pairs"] += time.perf_counter() - started
        if old is None or new is None:
            continue
        steps += 1
        busiest = max(busiest, len(old.tracks))
        differences += not np.array_equal(old.labels, new.labels)
        apart = np.linalg.norm(old.pos_now_m[:, None] - old.pos_now_m[None], axis=-1)
        for ego in range(len(old.tracks)):
            nodes = np.flatnonzero(apart[ego] <= PERCEPTION_RADIUS_M)
            nodes = np.concatenate([[ego], nodes[nodes != ego]])
            mine = [
                agglomerative_groups(
                    d[np.ix_(nodes, nodes)], rule.linkage, max_distance=rule.max_distance_m
                )
                for d in (old.distances, new.distances)
            ]
            differences += not np.array_equal(*mine)
            egos += 1
    timing = ", ".join(f"{k} {1000 * v / max(steps, 1):.2f} ms" for k, v in seconds.items())
    print(
        f"{Path(args.file).name}: {steps} steps (up to {busiest} people), {egos} people's own "
        f"groupings; {differences} differences; per step: {timing}"
    )


if __name__ == "__main__":
    main()
