"""Out-of-domain check: constant velocity and checkpoints on recordings from elsewhere.

Usage:
    python benchmarks/out_of_domain.py [--datasets benchmarks/ood/stanford_drone.toml,...]
        [--checkpoints trajectron++-univ-backward,grouptron-univ-backward]
        [--modes ml,ml-argmax,mean,ml-top10] [--default-model NAME] [--json FILE]

Scores the test parts of the development set's dataset descriptions (``benchmarks/ood/``: the
first three TrajNet Stanford Drone scenes and the three HERMES corridor runs of
``../shared/data/ood``, each read in its own format and resampled to 0.4 s) with the same code
as ``grouptron report --out-of-domain``, and prints that section: per recording (of
``--default-model``, or of every model with ``--default-model ''``) and point forecast of
``--modes`` the ADE/FDE with 95% intervals (time steps resampled), the paired difference to
constant velocity and FDE relative to it; then every model's FDE relative to constant velocity
by density (neighbours within 3 m at t), all recordings pooled. Never used for training or for
choosing a benchmark model.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.reporting.out_of_domain import (
    out_of_domain_markdown,
    prepare_out_of_domain,
    score_out_of_domain,
)

HERE = Path(__file__).resolve().parent
DEVELOPMENT_SET = ",".join(
    str(HERE / "ood" / f) for f in ("stanford_drone.toml", "hermes_corridor.toml")
)


def files_of_test_parts(descriptions: str) -> list[TrackSource]:
    """Every test file of the comma-separated dataset descriptions, with its layout."""
    sources = []
    for description in descriptions.split(","):
        dataset = read_dataset(description)
        sources += [TrackSource.from_format(f, dataset.recording) for f in dataset.files("test")]
    return sources


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datasets", default=DEVELOPMENT_SET, help="comma-separated descriptions")
    parser.add_argument(
        "--checkpoints", default="trajectron++-univ-backward,grouptron-univ-backward"
    )
    parser.add_argument(
        "--modes",
        default="ml",
        help="comma-separated point forecasts: ml, ml-argmax, mean, ml-top10",
    )
    parser.add_argument(
        "--default-model",
        default=DEFAULT_CHECKPOINT,
        help="the checkpoint folder whose rows per recording and targets are shown ('': every "
        "model's rows, no targets)",
    )
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument(
        "--json",
        type=Path,
        help="also write FDE over constant velocity's per model (first of --modes), pooled and "
        "by density bin "
        "(``{'fde_over_cv': {model: {bin: ratio}}}``), for campaign/screen.py --table --ood",
    )
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    datasets = [read_dataset(path) for path in args.datasets.split(",") if path]
    paths = [resolve_checkpoint(c) for c in args.checkpoints.split(",") if c]
    modes = args.modes.split(",")
    recordings = prepare_out_of_domain(datasets)
    default = args.default_model or None  # '' shows every model's rows per recording
    result = score_out_of_domain(recordings, paths, modes, default_model=default)
    print("\n".join(out_of_domain_markdown(result)))
    if args.json:
        ratios: dict[str, dict[str, float]] = {}
        for row in result.pooled:
            if row.mode in (None, modes[0]):
                ratios.setdefault(row.model, {})[row.bin] = row.ratio
        args.json.write_text(json.dumps({"fde_over_cv": ratios}, indent=2) + "\n")


if __name__ == "__main__":
    main()
