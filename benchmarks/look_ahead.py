"""Does the reference's look-ahead neighbour window explain the paper's Grouptron gain?

Usage:
    python benchmarks/look_ahead.py [--runs campaign/runs] [--seeds 0,1,2] [--threads 2]

Scores, on the univ test set once, each seed's Grouptron and Trajectron++ trained in the
papers' protocol with the reference's neighbour window (``campaign/run.py --look-ahead``: run
folders ``<model>-univ-central[-sS]-look-ahead`` under ``--runs``) and the shipped runs of the
same seeds (``checkpoints/<model>-univ-central[-seedS]``), most likely forecast. Prints every
checkpoint's validation and test ML FDE (whole set and UNIV-40/45/50, the paper's definition),
then per seed the paired differences with 95% intervals over resampled time steps: each model
with the window minus without, and Grouptron minus Trajectron++ with and without it; last, the
mean and spread of the Grouptron - Trajectron++ difference over the seeds.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np
import torch

from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.reporting.report import subset_masks

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paired import score, validation_fde

REPO = Path(__file__).resolve().parents[1]
MODELS = ("grouptron", "trajectron++")


def checkpoints(runs: Path, seed: int) -> dict[tuple[str, bool], Path]:
    """(model, look-ahead) -> best.safetensors of one seed."""
    found = {}
    for model in MODELS:
        suffix = f"-s{seed}" if seed else ""
        found[(model, True)] = (
            runs / f"{model}-univ-central{suffix}-look-ahead" / "best.safetensors"
        )
        shipped = f"{model}-univ-central" + (f"-seed{seed}" if seed else "")
        found[(model, False)] = REPO / "checkpoints" / shipped / "best.safetensors"
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=REPO / "campaign" / "runs")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    data_dir = resolve_data_dir()
    seeds = [int(s) for s in args.seeds.split(",")]
    fde: dict[tuple[int, str, bool], np.ndarray] = {}
    masks: dict[str | None, np.ndarray | None] = {}
    steps = np.zeros(0)
    rows = []
    for seed in seeds:
        for (model, ahead), weights in checkpoints(args.runs, seed).items():
            split, scores, samples = score(weights, data_dir, "ml")
            if not masks:
                masks, steps = subset_masks(split, samples), time_step_ids(samples)
            assert len(scores.fde) == len(steps), "test samples differ between checkpoints"
            fde[(seed, model, ahead)] = scores.fde
            cells = " | ".join(f"{scores.summary(m).fde:.3f}" for m in masks.values())
            name = weights.parent.name
            rows.append(f"| {name} | {validation_fde(weights):.3f} | {cells} |")
    names = [n or "univ" for n in masks]
    print("| checkpoint | val ML FDE | " + " | ".join(f"test {n}" for n in names) + " |")
    print("|---|---|" + "---|" * len(names))
    print("\n".join(rows))
    print("\n| seed | difference | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    gaps: dict[bool, list[float]] = {True: [], False: []}
    for seed in seeds:
        pairs = {
            "Grouptron: window - shipped": (("grouptron", True), ("grouptron", False)),
            "Trajectron++: window - shipped": (("trajectron++", True), ("trajectron++", False)),
            "with window: Grouptron - Trajectron++": (("grouptron", True), ("trajectron++", True)),
            "shipped: Grouptron - Trajectron++": (("grouptron", False), ("trajectron++", False)),
        }
        for label, (b, a) in pairs.items():
            difference = fde[(seed, *b)] - fde[(seed, *a)]
            cells = []
            for keep in masks.values():
                keep = np.ones(len(difference), bool) if keep is None else keep
                paired = mean_interval(difference[keep], steps[keep])
                cells.append(f"{paired.mean:+.3f} [{paired.low:+.3f}, {paired.high:+.3f}]")
            print(f"| {seed} | {label} | " + " | ".join(cells) + " |")
        for ahead in (True, False):
            gaps[ahead].append(float(np.mean(fde[(seed, "grouptron", ahead)] -
                                             fde[(seed, "trajectron++", ahead)])))  # fmt: skip
    if len(seeds) > 1:
        for ahead, label in ((True, "with the window"), (False, "shipped")):
            values = gaps[ahead]
            print(f"\nGrouptron - Trajectron++ on univ, {label}: "
                  f"{statistics.mean(values):+.3f} +- {statistics.stdev(values):.3f} m over "
                  f"{len(values)} seeds ({', '.join(f'{v:+.3f}' for v in values)})")  # fmt: skip


if __name__ == "__main__":
    main()
