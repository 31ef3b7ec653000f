"""Seed variance: Trajectron++ and Grouptron trained with several seeds on one split.

Usage:
    python benchmarks/seed_study.py [--split univ] [--seeds 0,1,2] [--epochs 10]
                                    [--warm-start campaign/runs] [--out runs/seeds]
                                    [--data-dir DIR]

Trains (or resumes, or reuses) ``OUT/<model>-<split>-s<seed>`` with
``grouptron train --split SPLIT --model MODEL --seed SEED --epochs EPOCHS`` (central
derivatives, default recipe; with ``--warm-start DIR`` each run continues
``DIR/<model>-<split>-central/last.safetensors`` for EPOCHS more epochs, so the seeds differ in
the shuffling and augmentation of those epochs), then scores every run's ``best.safetensors``
on the split's test set (most likely) and, for univ, on UNIV-40/45/50. Prints per-seed
FDE/ADE, mean +- standard deviation per model, and the Grouptron - Trajectron++ FDE difference
per seed.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

import torch

from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.evaluation.evaluate import score_samples
from grouptron.evaluation.test_sets import load_test_set
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import uses_groups
from grouptron.reporting.report import subset_masks

MODELS = ("trajectron++", "grouptron")


def train_run(
    model: str, split: str, seed: int, epochs: int, out: Path, warm_start: str | None
) -> None:
    """Train (or resume to ``epochs``) one run with the command-line tool."""
    argv = [sys.executable, "-m", "grouptron.cli", "train", "--split", split, "--model", model,
            "--seed", str(seed), "--epochs", str(epochs), "--out", str(out), "--quiet"]  # fmt: skip
    if (out / "last.safetensors").exists():
        argv.append("--resume")
    elif warm_start:
        argv += ["--init-from", f"{warm_start}/{model}-{split}-central/last.safetensors"]
    subprocess.run(argv, check=True)


def score_run(path: Path, data_dir: Path) -> dict[str | None, tuple[float, float]]:
    """(FDE, ADE) of the most likely prediction on the test set and its UNIV-N subsets."""
    model, config = load_trained_model(path)
    groups_config = config.groups if uses_groups(config) else None
    samples, groups = load_test_set(
        data_dir, config.split, config.data, None, group_config=groups_config
    )
    (scores,) = score_samples(model, config, samples, ("ml",), groups=groups)
    out = {}
    for subset, keep in subset_masks(config.split, samples).items():
        summary = scores.summary(keep)
        out[subset] = (summary.fde, summary.ade)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", default="univ")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--warm-start", help="continue the central runs in this folder")
    parser.add_argument("--out", default="runs/seeds")
    parser.add_argument("--data-dir")
    args = parser.parse_args()
    torch.set_num_threads(2)
    data_dir = resolve_data_dir(args.data_dir)
    seeds = [int(s) for s in args.seeds.split(",")]
    results: dict[tuple[str, int], dict[str | None, tuple[float, float]]] = {}
    for seed in seeds:
        for model in MODELS:
            run = Path(args.out) / f"{model}-{args.split}-s{seed}"
            if not (run / "done").exists():
                train_run(model, args.split, seed, args.epochs, run, args.warm_start)
                (run / "done").write_text("trained\n")
            results[model, seed] = score_run(run / "best.safetensors", data_dir)
    subsets = list(results[MODELS[0], seeds[0]])
    names = [s or args.split for s in subsets]
    how = (
        f"{args.epochs} more epochs from {args.warm_start}"
        if args.warm_start
        else (f"{args.epochs} epochs from scratch")
    )
    print(f"{args.split}, {how}, seeds {seeds}: most likely FDE/ADE on test (m)")
    print(f"{'model':<14} {'seed':>5} " + " ".join(f"{n:>13}" for n in names))
    for model in MODELS:
        for seed in seeds:
            cells = " ".join(f"{results[model, seed][s][0]:6.3f}/{results[model, seed][s][1]:.3f}"
                             for s in subsets)  # fmt: skip
            print(f"{model:<14} {seed:>5} {cells}")
        fdes = {s: [results[model, seed][s][0] for seed in seeds] for s in subsets}
        print(f"{model:<14} {'mean':>5} " + " ".join(
            f"{statistics.mean(v):6.3f}+-{statistics.stdev(v) if len(v) > 1 else 0:.3f}"
            for v in fdes.values()))  # fmt: skip
    for seed in seeds:
        diff = [100 * (results["grouptron", seed][s][0] / results["trajectron++", seed][s][0] - 1)
                for s in subsets]  # fmt: skip
        print(f"Grouptron vs Trajectron++ FDE, seed {seed}: "
              + ", ".join(f"{n} {d:+.1f}%" for n, d in zip(names, diff, strict=True)))  # fmt: skip


if __name__ == "__main__":
    main()
