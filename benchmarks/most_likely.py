"""Accuracy of the most likely forecast against how many latent values it is made of.

Usage:
    python benchmarks/most_likely.py [--checkpoints NAME,NAME] [--split univ]
                                     [--latent-values 1,2,3,5,25] [--threads 1]

On the validation files of the checkpoint's split (never its test files): every latent value
is decoded once, following its means; for each k the most likely forecast is the per-step mode
of the mixture of the k most probable latent values, integrated (k = 1 is the argmax latent,
k = Z the benchmark's ML). Prints ADE and FDE of each k over the samples with 8 observed and
12 future steps, with a 95% bootstrap interval of the FDE difference to all Z (over samples).
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from grouptron.data.locate import resolve_data_dir, split_files
from grouptron.data.recording import RecordingFormat
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.batch import batches
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import decode_every_latent, most_likely_of_decoded_top


def errors_by_top(name: str, split: str, tops: list[int]) -> dict[int, np.ndarray]:
    """(S, 2) ADE and FDE per validation sample for each number of latent values."""
    model, config = load_trained_model(resolve_checkpoint(name))
    files = split_files(resolve_data_dir(), split, "val")
    samples = recording_samples(files, RecordingFormat(), config.data)
    groups = groups_for_model(samples, config)
    H, dt = config.data.horizon_steps, config.data.dt_s
    out: dict[int, list[np.ndarray]] = {k: [] for k in tops}
    with torch.inference_mode():
        for _, batch in batches(samples, config, 512, groups):
            encoding, velocity = decode_every_latent(model.eval(), batch, H)
            for k in tops:
                forecast = most_likely_of_decoded_top(encoding, velocity, k, dt)
                error = (forecast - batch.fut_rel_m).norm(dim=-1)  # (B, H)
                out[k].append(torch.stack([error.mean(-1), error[:, -1]], -1).numpy())
    return {k: np.concatenate(v) for k, v in out.items()}


def interval(diff: np.ndarray, seed: int = 0, draws: int = 2000) -> tuple[float, float]:
    """95% bootstrap interval of the mean of per-sample differences."""
    rng = np.random.default_rng(seed)
    means = diff[rng.integers(0, len(diff), (draws, len(diff)))].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--checkpoints", default="trajectron++-univ-backward,grouptron-univ-backward"
    )
    parser.add_argument("--split", default="univ")
    parser.add_argument("--latent-values", default="1,2,3,5,25")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    tops = [int(k) for k in args.latent_values.split(",")]
    print(f"{'checkpoint':30} {'k':>3} {'samples':>8} {'ADE m':>7} {'FDE m':>7}  FDE - FDE(all)")
    for name in args.checkpoints.split(","):
        errors = errors_by_top(name, args.split, tops)
        full = errors[max(tops)][:, 1]
        for k in tops:
            ade, fde = errors[k].mean(axis=0)
            low, high = interval(errors[k][:, 1] - full)
            print(
                f"{name:30} {k:>3} {len(errors[k]):>8} {ade:>7.3f} {fde:>7.3f}  "
                f"{fde - full.mean():+.3f} [{low:+.3f}, {high:+.3f}]"
            )


if __name__ == "__main__":
    main()
