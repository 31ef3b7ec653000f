"""Fit the calibration a deployment checkpoint ships with, on files it never trained on.

Usage:
    python campaign/ship_calibration.py [NAME ...] [--threads 1]

For each deployment checkpoint (default: the three crowds-trained ones), every person with 8
observed and 12 future steps in the held-back validation files of its dataset description
(``campaign/deployment/eth-ucy-and-crowds.toml``: the forum's August day and two campus
sequences; the model trained on every ETH/UCY file, so none is held back there) is forecast
with the checkpoint's own point forecast and scored against its region's shape (the
Mahalanobis distance under the point forecast's own mixture); the split-conformal radii per
step and q, the whole-path radii, and the files' density and walking speed are written to
``checkpoints/NAME/calibration.json``, which ``Predictor``, ``predict``, ``plot`` and
``export`` then use where no other calibration is given. Why this shape and not the whole
mixture's, and what the shipped radii hold on recordings from elsewhere: benchmarks/RESULTS.md,
"Regions that transfer" and "A shipped calibration".
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import torch

from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.neighbours import scene_conditions
from grouptron.data.prepare.scene import build_scene
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.calibration import calibrate, save_calibration, weights_digest
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.predict import default_point_forecast

REPO = Path(__file__).resolve().parents[1]
DEPLOYMENT = (
    "grouptron-robust-residual-crowds-backward",
    "grouptron-robust-residual-crowds-backward-seed1",
    "grouptron-robust-residual-crowds-backward-seed2",
)
CALIBRATION_FILE = "calibration.json"


def ship(name: str) -> Path:
    """Write ``checkpoints/NAME/calibration.json`` and return its path."""
    folder = REPO / "checkpoints" / name
    model, config = load_trained_model(folder / "best.safetensors")
    dataset = read_dataset(REPO / config.dataset)
    sources = [TrackSource.from_format(f, dataset.recording) for f in dataset.files("val")]
    samples = recording_samples(sources, config.data)
    forecast = default_point_forecast(config)
    names = ", ".join(Path(s.path).name for s in sources)
    source = f"held-back files of {dataset.name}: {names}"
    digest = weights_digest(folder / "best.safetensors")
    calibration = calibrate(model, config, samples, forecast, source, digest)
    conditions = [_conditions(s, config) for s in sources]
    density, speed = (float(np.median([c[i] for c in conditions])) for i in (0, 1))
    calibration = dataclasses.replace(calibration, density=density, speed_mps=speed)
    out = folder / CALIBRATION_FILE
    save_calibration(calibration, out)
    return out


def _conditions(source: TrackSource, config) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """A file's median neighbours within 3 m and median walking speed."""
    table, _ = read_track_file(source, config.data.frames_per_step, config.data.dt_s)
    scene = build_scene(table, config.data, name=Path(source.path).stem)
    return scene_conditions(scene, config.data.perception_radius_m)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", default=list(DEPLOYMENT))
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    for name in args.names:
        out = ship(name)
        print(f"wrote {out.relative_to(REPO)}", flush=True)


if __name__ == "__main__":
    main()
