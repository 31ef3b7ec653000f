"""Conformal radii of a checkpoint's prediction regions from a recording of a site
(``grouptron calibrate``), written as a calibration file that ``predict``, ``plot`` and
``Predictor(calibration=...)`` read.

    from grouptron.data.formats.track_files import TrackFile
    from grouptron.workflows.calibrate import calibrate_tracks
    calibration = calibrate_tracks(TrackFile("monday.csv", columns="t,id,x,y"), Path("site.json"))
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

from grouptron.data.formats.track_files import TrackFile, read_track_file
from grouptron.data.prepare.neighbours import scene_conditions
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.inference.calibration import (
    MIN_FORECASTS,
    RegionCalibration,
    calibrate,
    save_calibration,
    weights_digest,
)
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint, warn_look_ahead
from grouptron.io import refuse_folder
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.forecaster import latent_values_of
from grouptron.model.predict import default_point_forecast
from grouptron.point_forecast import PointForecast

log = logging.getLogger(__name__)


def calibrate_tracks(
    tracks: TrackFile,
    out: Path,
    checkpoint: str | Path = DEFAULT_CHECKPOINT,
    forecast: PointForecast | str | None = None,
) -> RegionCalibration:
    """Score every person of ``tracks`` with a full history and future against the regions of
    ``checkpoint``'s point forecast ``forecast`` (None: the model's own) and write the conformal
    radii to ``out`` (checked before the work); returns them."""
    named = None if forecast is None else PointForecast.parse(forecast)  # before the work
    refuse_folder(out, inputs=(tracks.path,))
    path = resolve_checkpoint(checkpoint)
    model, experiment = load_trained_model(path)
    warn_look_ahead(checkpoint, experiment.data.derivatives)
    table, _ = read_track_file(tracks, experiment.data.frames_per_step)
    data = dataclasses.replace(experiment.data, frames_per_step=table.frames_per_step)
    experiment = dataclasses.replace(experiment, data=data)
    scene = build_scene(table, data, name=str(tracks.path))
    samples = scene_samples(scene, data, data.history_steps, require_future=True)
    point = default_point_forecast(experiment) if named is None else named
    point = point.for_model(latent_values_of(experiment))
    digest = weights_digest(path)
    calibration = calibrate(model, experiment, samples, point, str(tracks.path), digest)
    density, speed = scene_conditions(scene, data.perception_radius_m)
    calibration = dataclasses.replace(calibration, density=density, speed_mps=speed)
    if calibration.samples < 10 * MIN_FORECASTS:
        log.warning(
            "%s: calibrated from %d forecasts; regions need at least %d (and q = 0.9 needs 9, "
            "0.99 needs 99); a few hundred make the radii steady%s",
            out,
            calibration.samples,
            MIN_FORECASTS,
            "" if calibration.samples >= MIN_FORECASTS else ": predict and plot refuse it",
        )
    save_calibration(calibration, out)
    return calibration
