"""Calibrated prediction regions on held-back parts of recordings from elsewhere.

Usage:
    python benchmarks/calibration.py [--checkpoint NAME] [--datasets A.toml,B.toml]
                                     [--q 0.5,0.9] [--blocks 2] [--threads 1]
                                     [--forecast ml-top10] [--by-site]

Every test file of the out-of-domain descriptions (default: the development set,
``$GROUPTRON_OOD``) is cut in time into ``--blocks`` spans of equally many forecasts, taken in
turn for calibration and held back: with 2 (the default) the first half calibrates the regions
(what ``grouptron calibrate`` does with that part) and the second half is held back; with more,
both parts sample the whole recording (closer to the exchangeable case the guarantee assumes).
Prints, per recording and q, the share of the held-back truths inside the model's own regions
and inside the calibrated ones, at steps 1, 3, 6, 9 and 12 and the lowest and highest share
over the twelve steps. ``--by-site`` calibrates once per site instead of per file: the files of
one scene (``bookstore_0`` to ``bookstore_2``: a name that differs only in a trailing ``_N``),
each cut into its own spans, the calibration parts together and the held-back parts together.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource
from grouptron.data.prepare.samples import SampleSet, concatenate_samples
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.calibration import RegionCalibration, calibrate
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.engine import forecast_samples
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import calibrated_regions, prediction_regions
from grouptron.point_forecast import PointForecast

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET

STEPS = (1, 3, 6, 9, 12)


def held_back_inside(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    forecast: PointForecast,
    calibration: RegionCalibration,
    q: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(S, H) truths inside the model's own q-regions and inside the calibrated ones."""
    made = forecast_samples(model, config, samples, forecast, groups_for_model(samples, config))
    point, distribution = made.point, made.distribution
    assert distribution is not None
    truth = samples.fut_rel_m.astype(np.float64)  # (S, H, 2) relative to now, as the forecast
    own = prediction_regions(point, distribution, q).contains(truth)
    radius = calibration.radius(q)
    return own, calibrated_regions(point, distribution, q, radius).contains(truth)


def site_of(path: Path) -> str:
    """The scene a recording shows: its name without a trailing ``_N`` (a video's number)."""
    return re.sub(r"_\d+$", "", path.stem)


def split_in_time(samples: SampleSet, blocks: int) -> tuple[SampleSet, SampleSet]:
    """The recording cut in time into ``blocks`` spans of equally many forecasts: the even
    spans (calibration) and the odd ones (held back)."""
    edges = np.quantile(samples.step, np.linspace(0, 1, blocks + 1)[1:-1])
    block = np.searchsorted(edges, samples.step, side="right")  # 0 .. blocks - 1
    return samples.subset(block % 2 == 0), samples.subset(block % 2 == 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--datasets", default=DEVELOPMENT_SET)
    parser.add_argument("--q", default="0.5,0.9")
    parser.add_argument("--blocks", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--forecast", help="the point forecast (default: the model's own)")
    parser.add_argument("--by-site", action="store_true", help="one calibration per scene")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    qs = [float(q) for q in args.q.split(",")]
    model, config = load_trained_model(resolve_checkpoint(args.checkpoint))
    model.eval()
    named = PointForecast.parse(args.forecast) if args.forecast else None
    mode = (named or default_point_forecast(config)).for_model(config.model.latent_values)
    print(f"{args.checkpoint}: {mode} point forecast")
    steps = " | ".join(f"step {k}" for k in STEPS)
    print(f"| recording | calibration / held back | q | regions | {steps} | lowest-highest |")
    print("|---|---|---|---|" + "---|" * len(STEPS) + "---|")
    groups: dict[tuple[str, str], list[tuple[Path, SampleSet]]] = defaultdict(list)
    for description in (d for d in args.datasets.split(",") if d):
        dataset = read_dataset(description)
        for path in dataset.files("test"):
            source = TrackSource.from_format(path, dataset.recording)
            samples = recording_samples([source], config.data)
            key = site_of(path) if args.by_site else path.name  # sites never span datasets
            groups[(dataset.name, key)].append((path, samples))
    for (_, name), recordings in groups.items():
        parts = [split_in_time(samples, args.blocks) for _, samples in recordings]
        early = concatenate_samples([part[0] for part in parts])
        late = concatenate_samples([part[1] for part in parts])
        calibration = calibrate(model, config, early, mode, name)
        for q in qs:
            own, sized = held_back_inside(model, config, late, mode, calibration, q)
            for label, inside in (("own", own), ("calibrated", sized)):
                share = inside.mean(axis=0)
                cells = " | ".join(f"{share[k - 1]:.3f}" for k in STEPS)
                print(
                    f"| {name} | {len(early)} / {len(late)} | {q:g} | {label} | "
                    f"{cells} | {share.min():.3f}-{share.max():.3f} |"
                )


if __name__ == "__main__":
    main()
