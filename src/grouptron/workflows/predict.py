"""Forecasts of every pedestrian of a track file, written as CSV rows, TrajNet++ predictions
or Foxglove scene updates (``grouptron predict``).

    from grouptron.data.formats.track_files import TrackFile
    from grouptron.workflows.predict import PredictRequest, predict_tracks
    done = predict_tracks(PredictRequest(TrackFile("tracks.txt"), Path("forecasts.csv")))
"""

from __future__ import annotations

import dataclasses
import io
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.formats.ndjson import write_forecast_ndjson
from grouptron.data.formats.reader import TrackTable
from grouptron.data.formats.ros_bag import BagTracks
from grouptron.data.formats.track_files import TrackFile, read_track_file
from grouptron.data.prepare.neighbours import scene_conditions
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import (
    RegionCalibration,
    calibration_for,
    condition_mismatch,
)
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint, warn_look_ahead
from grouptron.inference.forecast import Forecast
from grouptron.inference.learn_replay import Replay, replay_learning
from grouptron.inference.learning import LearningOptions, LearningStatus
from grouptron.inference.online import OnlineCalibration, replay
from grouptron.inference.site_model import save_site
from grouptron.inference.tracks import forecast_scene
from grouptron.io import refuse_folder, write_text_atomically
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.forecaster import Forecaster, latent_values_of
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import region_shapes
from grouptron.point_forecast import PointForecast
from grouptron.viz.foxglove import write_forecast_mcap

log = logging.getLogger(__name__)
SAMPLES = "samples"
"""The forecast that writes sampled futures instead of a point forecast."""


@dataclass(frozen=True)
class PredictRequest:
    """What to forecast, with which model, and where to write it.

    Attributes:
        tracks: the track file and how to read it (``tracks.frames_per_step`` None: the
            checkpoint's).
        out: where the forecasts go, by suffix: ``.mcap`` Foxglove scene updates (on a bag's
            clock and in its frame), ``.ndjson`` TrajNet++ predictions, else CSV rows (layout 2,
            docs/guide.md); an open text stream takes CSV rows (standard output).
        checkpoint: a shipped name or a ``.safetensors`` file.
        forecast: a point forecast (``PointForecast`` or its name), or ``"samples"`` for
            sampled futures (None: the model's own point forecast).
        samples: futures per pedestrian and frame of ``forecast`` ``samples`` (K).
        seed: of the sampled futures.
        regions: probabilities Q of the regions added per point (CSV; an MCAP draws the first).
        calibration: a ``grouptron calibrate`` file of this checkpoint for the regions' radii
            (None: the one the checkpoint ships with, where it has one; False: none).
        online: replay the file in time order, the regions' radii adapting to every forecast
            whose truth has arrived (``inference.online``; from ``calibration``, else from
            ``online_state`` where that file exists, else from the Gaussian radii).
        online_state: where the online radii are resumed from (if the file exists) and left
            when the replay ends.
        joint: whole-path regions: a forecast's 12 ellipses together hold its path with
            probability Q (needs a calibration).
        min_points: forecast pedestrians with at least this many observed steps in a row, 2
            to 8 (None: 8, the samples the evaluator scores).
        learn: replay the file in time order learning its site as a live session would
            (``inference.learning``; True or ``LearningOptions``): each forecast is made with
            the weights in use at its time, trained only on tracks completed by then.
        save_site: with ``learn``, the folder where the weights in use at the end and their
            card are kept (``Predictor.from_checkpoint`` loads it).
        device: where the network runs.
        progress: a progress bar.
    """

    tracks: TrackFile
    out: str | Path | TextIO
    checkpoint: str | Path = DEFAULT_CHECKPOINT
    forecast: PointForecast | str | None = None
    samples: int = 20
    seed: int = 0
    regions: tuple[float, ...] = ()
    calibration: str | Path | bool | None = None
    online: bool = False
    online_state: str | Path | None = None
    joint: bool = False
    min_points: int | None = None
    learn: bool | LearningOptions = False
    save_site: str | Path | None = None
    device: str | torch.device = "cpu"
    progress: bool = False

    def __post_init__(self) -> None:
        if self.save_site is not None and not self.learn:
            raise GrouptronError("--save-site keeps what --learn learnt: add --learn")
        if (self.online or self.online_state) and not self.regions:
            raise GrouptronError("--online adapts the radii of --regions: name their q")
        if self.joint and (self.online or not self.regions):
            raise GrouptronError("--joint draws whole-path --regions; online radii are per step")
        if self.online_state and not self.online:
            raise GrouptronError("--online-state keeps the radii of --online: add it")
        if self.forecast is not None and self.forecast != SAMPLES:
            object.__setattr__(self, "forecast", PointForecast.parse(self.forecast))
        if self.forecast == SAMPLES and (self.regions or self.calibration not in (None, False)):
            raise GrouptronError(
                "--regions and --calibration go with a point forecast (--forecast), not samples"
            )


@dataclass(frozen=True)
class Predicted:
    """What was written: ``count`` rows (CSV, ``.ndjson``), or with ``scene_updates`` scene
    updates (``.mcap``), of the forecasts of ``model_name`` (its ``derivatives``), named
    ``kind`` (the point forecast's name, or ``samples``); with learning, what it did."""

    forecast: Forecast
    count: int
    model_name: str
    derivatives: str
    kind: str
    scene_updates: bool
    learning: LearningStatus | None = None


def predict_tracks(request: PredictRequest) -> Predicted:
    """Forecast every (pedestrian, frame) of ``request.tracks`` with a full enough history and
    write the forecasts to ``request.out``; a central checkpoint's look-ahead is logged."""
    out = _out_path(request.out)
    if out is not None:
        refuse_folder(out, inputs=(request.tracks.path,))  # before the work, not after it
    path = resolve_checkpoint(request.checkpoint)
    model, experiment = load_trained_model(path)
    warn_look_ahead(request.checkpoint, experiment.data.derivatives)
    table, bag = read_track_file(request.tracks, experiment.data.frames_per_step)
    data = dataclasses.replace(experiment.data, frames_per_step=table.frames_per_step)
    experiment = dataclasses.replace(experiment, data=data)
    scene = build_scene(table, data, name=str(request.tracks.path))
    sampled = request.forecast == SAMPLES
    point = default_point_forecast(experiment)
    if isinstance(request.forecast, PointForecast):
        point = request.forecast.for_model(latent_values_of(experiment))
    named = request.calibration not in (None, False)
    if (request.regions or named) and out is not None and out.suffix == ".ndjson":
        raise GrouptronError("--regions and --calibration go with CSV or MCAP output")
    calibrated = calibration_for(request.calibration, experiment, point, str(path))  # before work
    if calibrated is not None and request.regions:
        differs = condition_mismatch(calibrated, *scene_conditions(scene, data.perception_radius_m))
        if differs:
            log.warning("%s: %s", calibrated.source or request.calibration, differs)
    learnt = _learnt(request, model, experiment, point, scene, str(path))
    forecast = forecast_scene(
        model,
        experiment,
        scene,
        point,
        num_samples=request.samples if sampled else 0,
        seed=request.seed,
        progress=request.progress,
        min_points=request.min_points,
        device=request.device,
        keep_distribution=bool(request.regions),
        replay=learnt,
    )
    if request.online:
        start = _online_start(request, data.horizon_steps, calibrated)
        forecast = _replayed_online(forecast, table, start, request)
    else:
        forecast = dataclasses.replace(forecast, calibration=calibrated)
    kind = SAMPLES if sampled else point.name
    status = None if learnt is None else learnt.status
    done = Predicted(forecast, 0, experiment.model_name, data.derivatives, kind, False, status)
    if out is not None and out.suffix == ".mcap":
        count = _write_mcap(out, forecast, table, bag, data.dt_s, request.regions)
        return dataclasses.replace(done, count=count, scene_updates=True)
    names = None if bag is None or bag.numeric else bag.names  # a bag's own names, kept
    count = _write_rows(request, forecast, table, sampled, data.horizon_steps, names)
    return dataclasses.replace(done, count=count)


def _learnt(
    request: PredictRequest,
    model: Forecaster,
    experiment: ExperimentConfig,
    point: PointForecast,
    scene: Scene,
    source: str,
) -> Replay | None:
    """The replay of online learning along the file (None without ``learn``); the weights in
    use at its end kept in ``request.save_site``."""
    if not request.learn:
        return None
    options = request.learn if isinstance(request.learn, LearningOptions) else LearningOptions()
    learnt = replay_learning(model, experiment, point, scene, options, progress=request.progress)
    if request.save_site is not None:
        learner = learnt.learner
        save_site(request.save_site, learner.model, experiment, learner.status, source)
    return learnt


def _online_start(
    request: PredictRequest, horizon: int, calibrated: RegionCalibration | None
) -> OnlineCalibration:
    """Where the online radii start: a saved state to resume, else the calibration's."""
    state = request.online_state
    if state is not None and Path(state).is_file():
        if calibrated is not None:
            raise GrouptronError(
                f"--online-state {state} resumes its own radii: leave out --calibration"
            )
        return OnlineCalibration.load(state)
    return OnlineCalibration.start(horizon, calibrated)


def _replayed_online(
    forecast: Forecast, table: TrackTable, state: OnlineCalibration, request: PredictRequest
) -> Forecast:
    """The forecasts with the radii an online calibration had in force when each was made,
    the file replayed in time order; the final state left in ``request.online_state``."""
    assert forecast.distribution is not None
    seen = (table.frame.astype(np.int64), table.ped_id, table.pos_m)
    shapes = region_shapes(forecast.point, forecast.distribution)
    made = (forecast.frames, forecast.ids, forecast.point, shapes)
    radii = replay(state, seen, made, table.frames_per_step, request.regions)
    if request.online_state is not None:
        state.save(request.online_state)
    return dataclasses.replace(forecast, calibration=radii)


def _out_path(out: str | Path | TextIO) -> Path | None:
    """The file to write (None: a stream)."""
    return Path(out) if isinstance(out, str | Path) else None


def _write_rows(
    request: PredictRequest,
    forecast: Forecast,
    table: TrackTable,
    sampled: bool,
    horizon: int,
    names: tuple[str, ...] | None = None,
) -> int:
    """Write the forecasts as TrajNet++ ``.ndjson`` or CSV rows (with ``names``, a bag's own
    names of the ids in the ``id`` column); returns how many rows."""
    out = _out_path(request.out)
    if out is not None and out.suffix == ".ndjson":
        _write_trajnet(out, forecast, table, sampled=sampled)
        return len(forecast) * horizon * (request.samples if sampled else 1)
    header, rows, formats = forecast.table(sampled, request.regions, table.times, request.joint)
    text = io.StringIO()
    text.write(",".join(header) + "\n")
    np.savetxt(text, rows, fmt=list(formats), delimiter=",")
    written = text.getvalue()
    if names is not None:  # the id column (the second) by name: "frame,id,..." rows
        lines = written.splitlines()
        named = [
            f"{first},{names[int(float(number))]},{rest}"
            for first, number, rest in (line.split(",", 2) for line in lines[1:])
        ]
        written = "\n".join([lines[0], *named]) + "\n"
    if out is not None:
        write_text_atomically(out, written)
    else:
        stream = request.out
        assert not isinstance(stream, str | Path)
        stream.write(written)
    return len(rows)


def _write_trajnet(path: Path, forecast: Forecast, table: TrackTable, *, sampled: bool) -> None:
    """Forecasts as TrajNet++ predictions, each scene with the pedestrian's observed rows."""
    rows = zip(table.ped_id.tolist(), table.frame.tolist(), table.pos_m, strict=True)
    position = {(p, f): xy for p, f, xy in rows}
    step = table.frames_per_step
    history = []
    for p, f in zip(forecast.ids.tolist(), forecast.frames.tolist(), strict=True):
        keys = [(int(p), int(f) - k * step) for k in range(7, -1, -1)]
        history.append(np.asarray([position[key] for key in keys if key in position]))
    positions = forecast.samples if sampled else forecast.point[:, None]
    assert positions is not None
    write_forecast_ndjson(
        path, forecast.frames, forecast.ids, positions, history, frames_per_step=step
    )


def _write_mcap(
    path: Path,
    forecast: Forecast,
    table: TrackTable,
    bag: BagTracks | None,
    dt_s: float,
    regions: tuple[float, ...],
) -> int:
    """Foxglove scene updates of ``forecast`` on the input's clock (a bag's stamps) and in its
    frame (``map`` for a file), each with the region of the first of ``regions``."""
    # A person's pieces never overlap in time: (frame, id) names one row of the table.
    _, person = np.unique(np.concatenate([table.ped_id, forecast.ids]), return_inverse=True)
    people = int(person.max()) + 1
    row_key = table.frame.astype(np.int64) * people + person[: len(table.ped_id)]
    wanted = forecast.frames.astype(np.int64) * people + person[len(table.ped_id) :]
    order = np.argsort(row_key)
    origins = table.pos_m[order[np.searchsorted(row_key[order], wanted)]]  # (N, 2)

    def time_of_frame(frame: int) -> float:
        return float(table.times.seconds(np.array([frame]))[0])

    names = (lambda i: f"{i:g}") if bag is None else bag.name
    frame_id = bag.frame_id if bag is not None and bag.frame_id else "map"
    region_q = regions[0] if regions else None
    return write_forecast_mcap(
        path, forecast, origins, time_of_frame, frame_id, dt_s, names, region_q
    )
