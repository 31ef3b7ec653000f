"""Do the learned detector's groups help a group-aware model forecast? Paired, on a crowd.

Usage:
    python benchmarks/learned_groups_forecasts.py [--checkpoint CKPT] [--tracks FILE]
        [--every 1] [--dense 40]

(default: ``grouptron-robust-residual-univ-backward`` on ``univ/test/students003.txt``)

A ``Predictor`` of a checkpoint whose model reads groups forecasts every ``--every``-th frame of
a recording it did not train on twice: with the groups of its own rule (what it trained with)
and with ``LEARNED_GROUPS`` (the shipped detector's links, remembering each pair over the
frames, which are forecast in order; cut per person as the model's own rule is). Scored where a
person has 8 observed and 12 future steps in the file: FDE of each, and the paired difference
learned - own with its 95% interval over resampled frames, over all such people and over those
at frames with at least ``--dense`` people.
"""

from __future__ import annotations

import argparse

import numpy as np

from grouptron.evaluation.uncertainty import mean_interval
from grouptron.groups.pair_memory import PairMemory
from grouptron.inference.predictor import Predictor
from grouptron.presets import LEARNED_GROUPS

HISTORY, HORIZON, FRAMES = 8, 12, 10


def truth_and_keys(rows: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """(frame, id) -> (12, 2) the file's future positions, for people with 8 observed and 12
    future steps around the frame."""
    position = {(int(f), int(i)): (x, y) for f, i, x, y in rows}
    found = {}
    for frame, pid in position:
        past = [(frame - FRAMES * k, pid) in position for k in range(HISTORY)]
        future = [position.get((frame + FRAMES * k, pid)) for k in range(1, HORIZON + 1)]
        if all(past) and all(p is not None for p in future):
            found[(frame, pid)] = np.array(future)
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", default="grouptron-robust-residual-univ-backward")
    parser.add_argument("--tracks", default="../shared/data/eth_ucy/univ/test/students003.txt")
    parser.add_argument("--every", type=int, default=1, help="every k-th frame of the grid")
    parser.add_argument("--dense", type=int, default=40, help="people at a dense frame")
    args = parser.parse_args()
    rows = np.loadtxt(args.tracks)
    wanted = truth_and_keys(rows)
    own = Predictor.from_checkpoint(args.checkpoint, check_speed=False)
    learned = Predictor.from_checkpoint(args.checkpoint, check_speed=False)
    learned.group_rule = LEARNED_GROUPS  # the model reads the learned groups instead
    learned.pair_memory = PairMemory()
    frames = sorted({f for f, _ in wanted})[:: args.every]
    fde: dict[str, list[float]] = {"own": [], "learned": []}
    at_frame, crowd = [], []
    for frame in frames:  # one forecast of everyone per frame and rule
        present = int((rows[:, 0] == frame).sum())
        made = {name: p.predict(rows, t=frame) for name, p in (("own", own), ("learned", learned))}
        for pid in made["own"].ids:
            future = wanted.get((frame, int(pid)))
            if future is None:
                continue
            for name, forecast in made.items():
                k = int(np.flatnonzero(forecast.ids == pid)[0])
                fde[name].append(float(np.linalg.norm(forecast.point[k, -1] - future[-1])))
            at_frame.append(frame)
            crowd.append(present)
    own_fde, learned_fde = np.array(fde["own"]), np.array(fde["learned"])
    steps, dense = np.array(at_frame), np.array(crowd) >= args.dense
    for label, keep in (("all", np.ones(len(steps), bool)), (f">= {args.dense} people", dense)):
        d = mean_interval(learned_fde[keep] - own_fde[keep], steps[keep])
        print(f"{label}: {int(keep.sum())} forecasts at {len(set(steps[keep]))} frames; FDE own "
              f"rule {own_fde[keep].mean():.3f} m, learned {learned_fde[keep].mean():.3f} m; "
              f"learned - own {d.mean:+.4f} [{d.low:+.4f}, {d.high:+.4f}] m")  # fmt: skip


if __name__ == "__main__":
    main()
