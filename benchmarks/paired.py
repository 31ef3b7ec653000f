"""Two checkpoints of one split, scored on the same test samples, side by side.

Usage:
    python benchmarks/paired.py CHECKPOINT_A CHECKPOINT_B [--mode ml] [--threads 1]
                                [--data-dir DIR]

For runs that ``grouptron report`` would treat as one (same model, split, derivatives and seed,
differing in something else, such as the training precision): prints each one's validation ML
FDE (from its ``selection.json``, the trainer's score on the whole validation part), its test
FDE/ADE in the chosen point-forecast mode and, for univ, on UNIV-40/45/50 (the paper's count),
and the paired FDE difference B - A with its 95% interval over resampled time steps.
CHECKPOINT_* is a run folder (its ``best.safetensors``) or a ``.safetensors`` file.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, score_samples
from grouptron.evaluation.test_sets import load_test_set
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import uses_groups
from grouptron.reporting.report import subset_masks


def weights_of(path: Path) -> Path:
    """A run folder's ``best.safetensors``, or the file itself."""
    return path / "best.safetensors" if path.is_dir() else path


def validation_fde(weights: Path) -> float:
    """The whole-validation ML FDE the trainer chose the weights by (NaN if not recorded)."""
    selection = weights.parent / "selection.json"
    if not selection.exists():
        return float("nan")
    return float(json.loads(selection.read_text())["full_val_ml_fde"])


def score(weights: Path, data_dir: Path, mode: str) -> tuple[str, SampleScores, object]:
    """(split, per-sample scores of ``mode`` on the test set, the samples)."""
    model, config = load_trained_model(weights)
    groups_config = config.groups if uses_groups(config) else None
    samples, groups = load_test_set(
        data_dir, config.split, config.data, None, group_config=groups_config
    )
    (scores,) = score_samples(model, config, samples, (mode,), groups=groups)
    return config.split, scores, samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint_a", type=Path)
    parser.add_argument("checkpoint_b", type=Path)
    parser.add_argument(
        "--mode", default="ml", help="point forecast: ml, ml-argmax, mean or ml-top10"
    )
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--data-dir")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    data_dir = resolve_data_dir(args.data_dir)
    weights = [weights_of(args.checkpoint_a), weights_of(args.checkpoint_b)]
    try:
        scored = [score(w, data_dir, args.mode) for w in weights]
    except GrouptronError as error:
        raise SystemExit(f"error: {error}") from None
    if scored[0][0] != scored[1][0]:
        raise SystemExit(f"error: the checkpoints are of different splits ({scored[0][0]}, "
                         f"{scored[1][0]})")  # fmt: skip
    split, _, samples = scored[0]
    steps = time_step_ids(samples)
    masks = subset_masks(split, samples)
    names = [s or split for s in masks]
    print(f"{split} test set, {args.mode} forecast; FDE/ADE in m")
    print(f"{'checkpoint':<60} {'val FDE':>8} " + " ".join(f"{n:>13}" for n in names))
    for w, (_, scores, _) in zip(weights, scored, strict=True):
        cells = " ".join(
            f"{scores.summary(m).fde:6.3f}/{scores.summary(m).ade:.3f}" for m in masks.values()
        )
        print(f"{w!s:<60} {validation_fde(w):8.3f} {cells}")
    difference = scored[1][1].fde - scored[0][1].fde  # (S,) B - A, metres
    cells = []
    for keep in masks.values():
        keep = np.ones(len(difference), bool) if keep is None else keep
        paired = mean_interval(difference[keep], steps[keep])
        cells.append(f"{paired.mean:+.3f} [{paired.low:+.3f}, {paired.high:+.3f}]")
    print("B - A FDE (95% interval over time steps): " + "; ".join(
        f"{n} {c}" for n, c in zip(names, cells, strict=True)))  # fmt: skip


if __name__ == "__main__":
    main()
