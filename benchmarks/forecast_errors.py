"""Where each point forecast goes wrong: its final error split along and across the direction
of travel, and how much its velocity changes from step to step.

Usage:
    python benchmarks/forecast_errors.py [--checkpoint trajectron++-univ-backward]
        [--datasets benchmarks/ood/hermes_corridor.toml] [--threads 1]

On the test parts of the dataset descriptions (every person with 8 observed and 12 future
steps who moves at least 0.1 m/s at t, so that the direction of travel is defined), for
``ml``, ``ml-argmax``, ``mean`` and constant velocity: FDE, the mean absolute error of the final
position along the current velocity (too fast or too slow) and across it (off to the side),
and the mean change of the forecast velocity between consecutive steps (m/s).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.batch import batches
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import predict_point
from grouptron.point_forecast import NAMED, PointForecast

HERE = Path(__file__).resolve().parent
MIN_SPEED_MPS = 0.1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default="trajectron++-univ-backward")
    parser.add_argument("--datasets", default=str(HERE / "ood" / "hermes_corridor.toml"))
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    path = resolve_checkpoint(args.checkpoint)
    model, config = load_trained_model(path)
    H, dt = config.data.horizon_steps, config.data.dt_s
    for dataset in (read_dataset(path) for path in args.datasets.split(",")):
        sources = [TrackSource.from_format(f, dataset.recording) for f in dataset.files("test")]
        samples = recording_samples(sources, config.data)
        groups = groups_for_model(samples, config)
        forecasts: dict[str, list[np.ndarray]] = {mode: [] for mode in NAMED}
        with torch.inference_mode():
            for _, batch in batches(samples, config, 512, groups):
                for mode in NAMED:
                    forecast = PointForecast.parse(mode)
                    positions = predict_point(model.eval(), batch, forecast, H, dt)
                    forecasts[mode].append(positions.double().numpy())  # (B, H, 2)
        truth = samples.fut_rel_m.astype(np.float64)  # (S, H, 2), relative to t
        velocity = (samples.hist_rel_m[:, -1] - samples.hist_rel_m[:, -2]) / dt  # (S, 2)
        steps = np.arange(1, H + 1)[None, :, None] * dt
        rows = {m: np.concatenate(v) for m, v in forecasts.items()}
        rows["constant velocity"] = velocity[:, None, :] * steps
        speed = np.linalg.norm(velocity, axis=1)
        moving = speed >= MIN_SPEED_MPS
        heading = velocity[moving] / speed[moving, None]
        side = np.stack([-heading[:, 1], heading[:, 0]], axis=1)
        print(
            f"\n{dataset.name} ({moving.sum()} samples moving at >= {MIN_SPEED_MPS} m/s, "
            f"{(~moving).sum()} left out), {path.parent.name}\n"
        )
        print("| forecast | FDE m | along m | across m | velocity change per step m/s |")
        print("|---|---|---|---|---|")
        for name, all_positions in rows.items():
            positions = all_positions[moving]
            error = positions[:, -1] - truth[moving, -1]  # (S, 2)
            speeds = np.diff(
                np.concatenate([np.zeros_like(positions[:, :1]), positions], 1), axis=1
            )
            change = np.linalg.norm(np.diff(speeds / dt, axis=1), axis=-1).mean()
            print(
                f"| {name} | {np.linalg.norm(error, axis=1).mean():.3f} | "
                f"{np.abs((error * heading).sum(1)).mean():.3f} | "
                f"{np.abs((error * side).sum(1)).mean():.3f} | {change:.3f} |"
            )


if __name__ == "__main__":
    main()
