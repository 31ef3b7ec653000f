"""Out-of-domain check: constant velocity and checkpoints on recordings from elsewhere.

Usage:
    python benchmarks/out_of_domain.py [--ood ../shared/data/ood]
        [--checkpoints trajectron++-univ-backward,grouptron-univ-backward] [--sdd-files 6]

Reads the development set described in ``<ood>/README.md`` with the project's own reader (the
TrajNet Stanford Drone scenes: ``frame id x y`` at 30 fps in metres; the HERMES corridor runs:
``id frame x y z`` at 16 fps in centimetres), resamples them to 0.4 s, and scores every person
with 8 observed and 12 future points. Prints one Markdown row per recording and model: samples,
most-likely ADE/FDE with the FDE's 95% interval (time steps resampled), the paired difference
to constant velocity on the same samples with its interval, and FDE relative to it; then FDE
relative to constant velocity by density (neighbours within 3 m at t). Never used for training
or model selection of benchmark models.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from grouptron.config import DataConfig
from grouptron.data.recording import RecordingFormat
from grouptron.data.subsets import density_masks, time_step_ids
from grouptron.evaluation.evaluate import constant_velocity_scores, score_samples
from grouptron.evaluation.recordings import recording_samples
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.groups.assign import assign_groups
from grouptron.inference.predictor import resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import uses_groups

FORMATS = {
    "trajnet_sdd": RecordingFormat(fps=30.0),
    "hermes_corridor_1d": RecordingFormat(
        columns=("id", "frame", "x", "y", "z"), fps=16.0, units="cm"
    ),
}


def recordings(root: Path, sdd_files: int) -> list[tuple[Path, RecordingFormat]]:
    found = []
    for folder, fmt in FORMATS.items():
        files = sorted((root / folder).glob("*.txt"))
        found += [(f, fmt) for f in (files[:sdd_files] if folder == "trajnet_sdd" else files)]
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--ood", type=Path, default=Path(__file__).resolve().parents[2] / "shared/data/ood"
    )
    parser.add_argument(
        "--checkpoints", default="trajectron++-univ-backward,grouptron-univ-backward"
    )
    parser.add_argument("--sdd-files", type=int, default=6, help="first N Stanford Drone files")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument(
        "--json",
        type=Path,
        help="also write the pooled sums (model and constant velocity FDE by density bin and "
        "overall, per model) to this file, for campaign/screen.py --table --ood",
    )
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    paths = [resolve_checkpoint(c) for c in args.checkpoints.split(",") if c]
    models = [(path.parent.name, *load_trained_model(path)) for path in paths]
    print("| recording | model | samples | ADE m | FDE m [95% interval] "
          "| FDE - CV m [95% interval] | FDE / CV |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    by_density: dict[str, dict[str, list[float]]] = {}
    for path, fmt in recordings(args.ood, args.sdd_files):
        samples = recording_samples([path], fmt, DataConfig(derivatives="backward"))
        steps = time_step_ids(samples)
        cv = constant_velocity_scores(samples, 12)
        rows = [("constant velocity", cv)]
        for label, model, config in models:
            ours = recording_samples([path], fmt, config.data)
            groups = (
                assign_groups(ours, config.groups, config.data.position_scale_m)
                if uses_groups(config)
                else None
            )
            (scores,) = score_samples(model, config, ours, ("ml",), groups=groups)
            if len(ours) != len(samples):
                raise SystemExit(f"{label}: {len(ours)} samples against constant velocity's "
                                 f"{len(samples)} on {path.name}")  # fmt: skip
            rows.append((label, scores))
        for name, scores in rows:
            fde = mean_interval(scores.fde, steps)
            diff = mean_interval(scores.fde - cv.fde, steps)
            ratio = scores.fde.mean() / cv.fde.mean()
            print(f"| {path.name} | {name} | {len(samples)} | {scores.ade.mean():.3f} | "
                  f"{fde.mean:.3f} [{fde.low:.3f}, {fde.high:.3f}] | "
                  f"{diff.mean:+.3f} [{diff.low:+.3f}, {diff.high:+.3f}] | "
                  f"{ratio:.3f} |")  # fmt: skip
            pooled = by_density.setdefault(name, {}).setdefault("all", [0.0, 0.0])
            pooled[0] += float(scores.fde.sum())
            pooled[1] += float(cv.fde.sum())
            for bin_name, keep in density_masks(samples).items():
                if keep.sum() >= 20:
                    entry = by_density.setdefault(name, {}).setdefault(bin_name, [0.0, 0.0])
                    entry[0] += float(scores.fde[keep].sum())
                    entry[1] += float(cv.fde[keep].sum())
    if args.json:
        ratios = {m: {b: s[0] / s[1] for b, s in per.items()} for m, per in by_density.items()}
        args.json.write_text(json.dumps({"fde_over_cv": ratios}, indent=2) + "\n")
    print("\nFDE relative to constant velocity by density (all recordings pooled):\n")
    order = {b: i for i, b in enumerate(density_masks(samples))}
    names = sorted(
        {b for per in by_density.values() for b in per if b != "all"}, key=order.__getitem__
    )
    print("| model | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for model_name, per in by_density.items():
        cells = [f"{per[b][0] / per[b][1]:.3f}" if b in per else "-" for b in names]
        print(f"| {model_name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
