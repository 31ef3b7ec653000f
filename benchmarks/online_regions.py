"""Online and whole-path regions on recordings from elsewhere, replayed in time order.

Usage:
    python benchmarks/online_regions.py [--checkpoint NAME] [--datasets A.toml,B.toml]
                                        [--calibration FILE|shipped|none] [--q 0.9]
                                        [--threads 1] [--halves] [--learning-rate 0.1]

Every test file of the out-of-domain descriptions (default: the development set) is forecast
with the checkpoint's own point forecast, as ``grouptron predict`` does, and replayed in time
order with online calibration (``inference.online``, what ``predict --online`` and a live
session do): at each step the truths that arrived are scored first, then the forecasts made
there get the radii in force. Prints per recording the long-run coverage (the share of truths
inside the radius in force when their forecast was made) at steps 4, 8 and 12 with the
regions' mean area (m^2) beside it, the same for the static starting radii, and, with a
calibration that has whole-path radii, the share of whole 4.8 s paths inside the ``--q``
whole-path regions and their areas at those steps. ``--halves`` instead calibrates each
file on its first half (``grouptron calibrate``'s split conformal) and replays its second half
from there, static and online. Starting radii: ``shipped`` (the checkpoint's own calibration,
the default where it ships one), a calibration file, or ``none`` (the Gaussian radii).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import torch

from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.inference.calibration import (
    RegionCalibration,
    calibrate,
    load_calibration,
    shipped_calibration,
)
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.forecast import Forecast
from grouptron.inference.online import LEARNING_RATE, OnlineCalibration, replay
from grouptron.inference.tracks import forecast_scene
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import region_shapes, shape_distances

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET, files_of_test_parts

STEPS = (4, 8, 12)


def replayed(
    forecast: Forecast, seen: tuple[np.ndarray, ...], step: int, start: OnlineCalibration, q: float
) -> tuple[OnlineCalibration, np.ndarray]:
    """The state after an online replay, and the (N, H) radii in force per forecast at q."""
    assert forecast.distribution is not None
    shapes = region_shapes(forecast.point, forecast.distribution)
    made = (forecast.frames, forecast.ids, forecast.point, shapes)
    radii = replay(start, (seen[0], seen[1], seen[2]), made, step, (q,))
    return start, radii.radius(q)


def truths(forecast: Forecast, seen: tuple[np.ndarray, ...], step: int) -> np.ndarray:
    """(N, H, 2) the observed positions k steps after each forecast (NaN where unseen)."""
    frames, ids, xy = seen
    names, index = np.unique(np.concatenate([ids, forecast.ids]), return_inverse=True)
    people = len(names)
    key = frames.astype(np.int64) * people + index[: len(ids)]
    order = np.argsort(key)
    H = forecast.point.shape[1]
    ahead = forecast.frames[:, None] + step * np.arange(1, H + 1)[None, :]  # (N, H)
    wanted = ahead * people + index[len(ids) :, None]
    at = np.clip(np.searchsorted(key[order], wanted), 0, len(key) - 1)
    found = key[order][at] == wanted
    out = np.full((len(forecast), H, 2), np.nan)
    out[found] = xy[order][at][found]
    return out


def score_file(
    source: TrackSource, args: argparse.Namespace, start: RegionCalibration | None
) -> list[str]:
    """Rows of the report for one recording."""
    path = resolve_checkpoint(args.checkpoint)
    model, config = load_trained_model(path)
    table, _ = read_track_file(source, config.data.frames_per_step, config.data.dt_s)
    data = dataclasses.replace(config.data, frames_per_step=table.frames_per_step)
    config = dataclasses.replace(config, data=data)
    scene = build_scene(table, data, name=Path(source.path).stem)
    point = default_point_forecast(config)
    forecast = forecast_scene(model, config, scene, point, keep_distribution=True)
    seen = (table.frame.astype(np.int64), table.ped_id, table.pos_m)
    step, H = table.frames_per_step, data.horizon_steps
    truth = truths(forecast, seen, step)
    assert forecast.distribution is not None
    scores = shape_distances(forecast.point, forecast.distribution, np.nan_to_num(truth))
    known = ~np.isnan(truth[..., 0])
    # An ellipse of radius r under shape S has area pi r^2 sqrt(det S): (N, H) for areas.
    unit_area = np.pi * np.sqrt(np.linalg.det(region_shapes(forecast.point, forecast.distribution)))
    name = Path(source.path).stem
    if args.halves:
        made = (model, config, scene, unit_area)
        return _halves(name, forecast, seen, step, scores, known, made, args)
    online = OnlineCalibration.start(H, start, args.learning_rate)
    state, radii = replayed(forecast, seen, step, online, args.q)
    rows = [_row(name, "online", scores, radii, known, unit_area)]
    if start is not None:
        rows.append(
            _row(
                name,
                "static",
                scores,
                np.broadcast_to(start.radius(args.q), radii.shape),
                known,
                unit_area,
            )
        )
        if len(start.joint_radii):
            whole = known.all(axis=1)
            path_radius = start.radius(args.q, joint=True)
            inside = (scores <= path_radius).all(axis=1)
            share = f"{inside[whole].mean():.1%} of {whole.sum()} paths"
            area = (unit_area * path_radius**2)[whole][:, [k - 1 for k in STEPS]].mean(axis=0)
            sizes = " / ".join(f"{a:.2f}" for a in area)
            rows.append(f"| {name} | whole path (static) | {share}, {sizes} m^2 | | |")
    del state
    return rows


def _halves(
    name: str,
    forecast: Forecast,
    seen: tuple[np.ndarray, ...],
    step: int,
    scores: np.ndarray,
    known: np.ndarray,
    made: tuple,
    args: argparse.Namespace,
) -> list[str]:
    """Calibrate on the first half of the file's forecast frames, replay the second half."""
    model, config, scene, unit_area = made
    middle = np.median(forecast.frames)
    samples = scene_samples(scene, config.data, config.data.history_steps)
    frames = scene.first_frame + samples.step * scene.frames_per_step
    first = samples.subset(frames + config.data.horizon_steps * step <= middle)
    calibration = calibrate(model, config, first, default_point_forecast(config))
    later = forecast.frames > middle
    second = dataclasses.replace(
        forecast,
        frames=forecast.frames[later],
        ids=forecast.ids[later],
        point=forecast.point[later],
        distribution=forecast.distribution.rows(later) if forecast.distribution else None,
        observed_points=None,
        filled_points=None,
    )
    H = config.data.horizon_steps
    online = OnlineCalibration.start(H, calibration, args.learning_rate)
    _, radii = replayed(second, seen, step, online, args.q)
    static = np.broadcast_to(calibration.radius(args.q), radii.shape)
    return [
        _row(name, "second half, online", scores[later], radii, known[later], unit_area[later]),
        _row(name, "second half, static", scores[later], static, known[later], unit_area[later]),
    ]


def _row(
    name: str,
    kind: str,
    scores: np.ndarray,
    radii: np.ndarray,
    known: np.ndarray,
    unit_area: np.ndarray,
) -> str:
    """Coverage at STEPS (the share of arrived truths inside the radius in force) and the
    regions' mean area (m^2)."""
    cells = []
    for k in STEPS:
        seen = known[:, k - 1]
        held = (scores[seen, k - 1] <= radii[seen, k - 1]).mean()
        area = (unit_area[seen, k - 1] * radii[seen, k - 1] ** 2).mean()
        cells.append(f"{held:.1%}, {area:.2f} m^2")
    return f"| {name} | {kind} | " + " | ".join(cells) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--datasets", default=DEVELOPMENT_SET)
    parser.add_argument("--calibration", default="shipped", help="shipped, a file, or none")
    parser.add_argument("--q", type=float, default=0.9)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--halves", action="store_true")
    parser.add_argument("--learning-rate", type=float, default=LEARNING_RATE)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    chosen: Path | None = None
    if args.calibration == "shipped":
        chosen = shipped_calibration(resolve_checkpoint(args.checkpoint))
    elif args.calibration != "none":
        chosen = Path(args.calibration)
    start = load_calibration(chosen) if chosen is not None else None
    print(f"starting radii: {chosen or 'the Gaussian radii'}; q = {args.q:g}")
    print("| recording | radii | " + " | ".join(f"step {k}" for k in STEPS) + " |")
    print("|---|---|" + "---|" * len(STEPS))
    for source in files_of_test_parts(args.datasets):
        for row in score_file(source, args, start):
            print(row, flush=True)


if __name__ == "__main__":
    main()
