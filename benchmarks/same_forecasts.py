"""Whether a change moves shipped models' forecasts: save them at one commit, compare at another.

Usage:
    python benchmarks/same_forecasts.py --save FILE.npz [--replay FILE] [--frames 14]
                                        [--checkpoints NAME,...]
    python benchmarks/same_forecasts.py --compare BEFORE.npz AFTER.npz

``--save`` streams the frames around the most crowded one of an ETH/UCY-layout recording
(default: the densest Grand Central file, ``../shared/data/crowds/gc/gc_043.txt``) through
each checkpoint's live session with its own point forecast and stores the last update's point
forecasts (N, 12, 2) and their distribution's means (N, M, 12, 2). Run it once per commit
with that commit's package first on the path (``PYTHONPATH=<worktree of it>/src``; this
script itself may be newer). ``--compare`` prints, per checkpoint and array, the largest
difference in metres and whether the two are bitwise equal.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

from grouptron import Predictor

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from streaming import recorded_frames  # noqa: E402

CHECKPOINTS = "default,grouptron-univ-backward,trajectron++-univ-backward"
"""The default model, a paper-style Grouptron and a plain Trajectron++."""


def forecasts(path: Path, frames: int, checkpoints: list[str]) -> dict[str, np.ndarray]:
    """``{checkpoint/point, checkpoint/means}`` of the last of ``frames`` live updates."""
    recorded = recorded_frames(path, frames)
    saved: dict[str, np.ndarray] = {}
    for name in checkpoints:
        predictor = (
            Predictor.from_checkpoint() if name == "default" else Predictor.from_checkpoint(name)
        )
        session = predictor.stream()
        for k, (ids, xy) in enumerate(recorded):
            forecast = session.update(10 * k, ids, xy)
        saved[f"{name}/point"] = np.asarray(forecast.point)
        saved[f"{name}/means"] = np.asarray(forecast.distribution.means)
    return saved


def compare(before: Path, after: Path) -> None:
    """Print the largest difference of every array the two files share."""
    with np.load(before) as old, np.load(after) as new:
        for key in old.files:
            if key not in new.files or old[key].shape != new[key].shape:
                print(f"{key}: not comparable (missing or reshaped)")
                continue
            largest = float(np.abs(old[key] - new[key]).max()) if old[key].size else 0.0
            equal = np.array_equal(old[key], new[key])
            print(f"{key}: largest difference {largest:.3g} m, bitwise equal: {equal}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    action = parser.add_mutually_exclusive_group(required=True)
    action.add_argument("--save", type=Path, metavar="FILE")
    action.add_argument("--compare", type=Path, nargs=2, metavar=("BEFORE", "AFTER"))
    densest = REPO.parent / "shared" / "data" / "crowds" / "gc" / "gc_043.txt"
    parser.add_argument("--replay", type=Path, default=densest)
    parser.add_argument("--frames", type=int, default=14)
    parser.add_argument("--checkpoints", default=CHECKPOINTS)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    if args.compare:
        compare(*args.compare)
        return
    torch.set_num_threads(args.threads)
    saved = forecasts(args.replay, args.frames, args.checkpoints.split(","))
    np.savez(args.save, **saved)
    print(f"{args.save}: {len(saved)} arrays of {len(args.checkpoints.split(','))} checkpoints")


if __name__ == "__main__":
    main()
