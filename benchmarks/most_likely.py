"""Accuracy of the most likely forecast against how many latent values it is made of.

Usage:
    python benchmarks/most_likely.py [--checkpoints NAME,NAME] [--split univ]
                                     [--latent-values 1,2,3,5,25] [--reference K]
                                     [--datasets benchmarks/ood/stanford_drone.toml,...]
                                     [--threads 1]

On the validation files of the split (never its test files) and, with ``--datasets``, on the
test parts of those dataset descriptions (the out-of-domain development set): every latent
value is decoded once, following its means; for each k the most likely forecast is the
per-step mode of the mixture of the k most probable latent values, integrated (k = 1 is the
argmax latent, k = Z the benchmark's ML). Prints ADE and FDE of each k over the samples with 8
observed and 12 future steps, with a 95% bootstrap interval (time steps resampled) of the FDE
difference to k = ``--reference`` (default: the largest k).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from grouptron.data.datasets.custom import DatasetDescription, read_dataset
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.track_files import TrackSource
from grouptron.evaluation.recordings import recording_samples
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.batch import batches
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import decode_every_latent, most_likely_of_decoded_top
from grouptron.reporting.out_of_domain import TEST_PART


def errors_by_top(
    name: str, split: str, tops: list[int], dataset: DatasetDescription | None = None
) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """(S, 2) ADE and FDE per sample for each number of latent values, and (S,) the time step
    of each sample: on the split's validation files, or on ``dataset``'s test part."""
    model, config = load_trained_model(resolve_checkpoint(name))
    if dataset is None:
        files = split_files(resolve_data_dir(), split, "val")
        sources = [TrackSource.from_format(f, RecordingFormat()) for f in files]
    else:
        fmt = dataset.recording
        sources = [TrackSource.from_format(f, fmt) for f in dataset.files(TEST_PART)]
    samples = recording_samples(sources, config.data)
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
    return {k: np.concatenate(v) for k, v in out.items()}, time_step_ids(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--checkpoints", default="trajectron++-univ-backward,grouptron-univ-backward"
    )
    parser.add_argument("--split", default="univ")
    parser.add_argument("--latent-values", default="1,2,3,5,25")
    parser.add_argument("--reference", type=int, help="k the differences are taken to")
    parser.add_argument("--datasets", default="", help="comma-separated dataset descriptions")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    tops = [int(k) for k in args.latent_values.split(",")]
    reference = args.reference or max(tops)
    if reference not in tops:
        parser.error(f"--reference {reference} must be one of --latent-values")
    sources: list[tuple[str, DatasetDescription | None]] = [(f"{args.split} val", None)]
    sources += [(Path(p).stem, read_dataset(Path(p))) for p in args.datasets.split(",") if p]
    print(
        f"{'checkpoint':30} {'files':>16} {'k':>3} {'samples':>8} {'ADE m':>7} {'FDE m':>7}  "
        f"FDE - FDE(k = {reference})"
    )
    for name in args.checkpoints.split(","):
        for label, dataset in sources:
            errors, steps = errors_by_top(name, args.split, tops, dataset)
            full = errors[reference][:, 1]
            for k in tops:
                ade, fde = errors[k].mean(axis=0)
                diff = mean_interval(errors[k][:, 1] - full, steps)
                print(
                    f"{name:30} {label:>16} {k:>3} {len(errors[k]):>8} {ade:>7.3f} {fde:>7.3f}  "
                    f"{diff.mean:+.4f} [{diff.low:+.4f}, {diff.high:+.4f}]"
                )


if __name__ == "__main__":
    main()
