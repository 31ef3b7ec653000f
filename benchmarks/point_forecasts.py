"""Which single forecast to return: the most likely (``ml``), the argmax latent's
(``ml-argmax``) or the mixture's mean (``mean``), on validation data only.

Usage:
    python benchmarks/point_forecasts.py [--checkpoints NAME_OR_PATH,...] [--threads 1]

For each checkpoint, on the validation files of its split (never its test files; an
all-locations checkpoint has none and is skipped): every sample with 8 observed and 12 future
steps, scored with the three point forecasts and constant velocity on the same samples. Prints
ADE/FDE per forecast and the paired FDE difference to ``ml`` with its 95% interval over
resampled time steps (samples of one step share a scene).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from grouptron.constants import SPLITS
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.track_files import TrackSource
from grouptron.evaluation.evaluate import constant_velocity_scores, score_samples
from grouptron.evaluation.recordings import recording_samples
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.point_forecast import NAMED

RUNS = Path(__file__).resolve().parents[1] / "campaign" / "runs"
DEFAULT = ",".join(
    ["trajectron++-univ-backward", "grouptron-univ-backward"]
    + [str(RUNS / f"{m}-univ-backward-s{s}") for m, s in (("trajectron++", 1), ("trajectron++", 2))]
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", default=DEFAULT, help="comma-separated names or paths")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    modes = tuple(NAMED)
    print("| checkpoint | split | samples | forecast | ADE m | FDE m | FDE - FDE(ml) m |")
    print("|---|---|---|---|---|---|---|")
    for name in args.checkpoints.split(","):
        path = resolve_checkpoint(name)
        model, config = load_trained_model(path)
        if config.split not in SPLITS:
            print(f"| {path.parent.name} | {config.split} | - | no validation part | | | |")
            continue
        files = split_files(resolve_data_dir(), config.split, "val")
        sources = [TrackSource.from_format(f, RecordingFormat()) for f in files]
        samples = recording_samples(sources, config.data)
        groups = groups_for_model(samples, config)
        steps = time_step_ids(samples)
        scored = score_samples(model, config, samples, modes, groups=groups)
        (ml,) = [s.fde for s in scored if s.mode == "ml"]
        cv = constant_velocity_scores(samples, config.data.horizon_steps)
        for label, scores in [(s.mode, s) for s in scored] + [("constant velocity", cv)]:
            diff = mean_interval(scores.fde - ml, steps)
            cell = "" if label == "ml" else f"{diff.mean:+.3f} [{diff.low:+.3f}, {diff.high:+.3f}]"
            print(
                f"| {path.parent.name} | {config.split} | {len(samples)} | {label} | "
                f"{scores.ade.mean():.3f} | {scores.fde.mean():.3f} | {cell} |"
            )


if __name__ == "__main__":
    main()
