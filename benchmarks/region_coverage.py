"""Coverage of prediction regions: how often the true position lies inside the q-region.

Usage:
    python benchmarks/region_coverage.py [--checkpoint NAME] [--split SPLIT]
                                         [--datasets A.toml,B.toml] [--q 0.5,0.9]
                                         [--threads 1] [--forecast ml-top10]

For every validation file of the checkpoint's split or dataset (never test files; ``--split`` for
another's) and every test file of the
out-of-domain descriptions (default: the development set, ``$GROUPTRON_OOD``), every person
with 8 observed and 12 future steps is forecast with the checkpoint's own point forecast
(``Predictor``'s default) and ``Forecast.regions(q)`` is drawn around it. Prints, per
recording and q, the share of true positions inside the ellipse at steps 1, 3, 6, 9 and 12
and over all steps, with a 95% interval over resampled time steps for the all-steps share,
and the same pooled over the validation files and over the out-of-domain files.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.track_files import TrackSource
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.engine import forecast_samples
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import prediction_regions
from grouptron.point_forecast import PointForecast

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET

STEPS = (1, 3, 6, 9, 12)


def inside_per_step(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    qs: list[float],
    forecast: PointForecast,
) -> dict[float, np.ndarray]:
    """Per q, (S, H) whether each truth is inside the region of point forecast ``forecast``."""
    groups = groups_for_model(samples, config)
    made = forecast_samples(model, config, samples, forecast, groups)
    assert made.distribution is not None
    truth = samples.fut_rel_m.astype(np.float64)  # (S, H, 2) relative to now, as the forecast
    return {q: prediction_regions(made.point, made.distribution, q).contains(truth) for q in qs}


def interval(hits: np.ndarray, steps: np.ndarray, draws: int = 1000) -> tuple[float, float]:
    """95% interval of the all-steps share, resampling time steps (people at one time step
    are not independent)."""
    rng = np.random.default_rng(0)
    unique, owner = np.unique(steps, return_inverse=True)
    per_step = np.bincount(owner, hits.mean(axis=1), len(unique))
    count = np.bincount(owner, minlength=len(unique)).astype(float)
    picks = rng.integers(0, len(unique), (draws, len(unique)))
    shares = per_step[picks].sum(axis=1) / count[picks].sum(axis=1)
    return float(np.percentile(shares, 2.5)), float(np.percentile(shares, 97.5))


def own_description(stored: Path) -> Path:
    """A run's dataset description: the path its config stores (absolute, as trained), or in
    a clone elsewhere the file of that name in this repository's ``campaign/deployment/``."""
    here = Path(__file__).resolve().parents[1] / "campaign" / "deployment" / stored.name
    return stored if stored.exists() or not here.exists() else here


def recordings(args: argparse.Namespace, data: DataConfig) -> list[tuple[str, SampleSet]]:
    """(name, samples) of every validation file and every out-of-domain test file."""
    out = []
    if args.own_dataset:  # a run on a dataset of its own: its description's val part
        own = read_dataset(own_description(Path(args.own_dataset)))
        validation = [(path, own.recording) for path in own.files("val")]
    else:
        validation = [
            (p, RecordingFormat()) for p in split_files(resolve_data_dir(), args.split, "val")
        ]
    for path, layout in validation:
        samples = recording_samples([TrackSource.from_format(path, layout)], data)
        out.append((f"{args.split} val: {path.name}", samples))
    for description in (d for d in args.datasets.split(",") if d):
        dataset = read_dataset(description)
        for path in dataset.files("test"):
            source = TrackSource.from_format(path, dataset.recording)
            samples = recording_samples([source], data)
            out.append((f"{dataset.name}: {path.name}", samples))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--split", help="whose validation files (default: the checkpoint's)")
    parser.add_argument("--datasets", default=DEVELOPMENT_SET)
    parser.add_argument("--q", default="0.5,0.9")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--forecast", help="the point forecast (default: the model's own)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    qs = [float(q) for q in args.q.split(",")]
    model, config = load_trained_model(resolve_checkpoint(args.checkpoint))
    model.eval()
    args.own_dataset = config.dataset if not args.split else ""
    args.split = args.split or config.split
    named = PointForecast.parse(args.forecast) if args.forecast else None
    mode = (named or default_point_forecast(config)).for_model(config.model.latent_values)
    print(f"{args.checkpoint}: {mode} point forecast")
    steps_header = " | ".join(f"step {k}" for k in STEPS)
    print(f"| recording | samples | q | {steps_header} | all steps [95%] |")
    print("|---|---|---|" + "---|" * len(STEPS) + "---|")
    pooled: dict[str, list[tuple[dict[float, np.ndarray], np.ndarray]]] = {}
    for name, samples in recordings(args, config.data):
        if not len(samples):
            continue
        inside = inside_per_step(model, config, samples, qs, mode)
        kind = "validation" if " val: " in name else "out of domain"
        offset = 10_000 * len(pooled.get(kind, []))  # keep each file's time steps apart
        pooled.setdefault(kind, []).append((inside, samples.step + offset))
        print_rows(name, inside, samples.step, qs)
    for kind, parts in pooled.items():
        inside = {q: np.concatenate([p[0][q] for p in parts]) for q in qs}
        print_rows(f"**{kind}, pooled**", inside, np.concatenate([p[1] for p in parts]), qs)


def print_rows(
    name: str, inside: dict[float, np.ndarray], steps: np.ndarray, qs: list[float]
) -> None:
    """One table row per q: coverage at STEPS and over all steps with its interval."""
    for q in qs:
        share = inside[q].mean(axis=0)  # (H,)
        low, high = interval(inside[q], steps)
        cells = " | ".join(f"{share[k - 1]:.3f}" for k in STEPS)
        total = f"{inside[q].mean():.3f} [{low:.3f}, {high:.3f}]"
        print(f"| {name} | {len(steps)} | {q:g} | {cells} | {total} |")


if __name__ == "__main__":
    main()
