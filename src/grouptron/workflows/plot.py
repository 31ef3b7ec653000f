"""Pictures of forecasts on a track file: one model's (or two side by side) at one frame, or
an animation over a range of frames (``grouptron plot``).

    from grouptron.data.formats.track_files import TrackFile
    from grouptron.workflows.plot import PlotRequest, plot_tracks
    print(plot_tracks(PlotRequest(TrackFile("students003.txt"), Path("f.png"), frame=3000)).summary)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from grouptron.data.formats.reader import TrackTable
from grouptron.data.formats.track_files import TrackFile, read_track_file, table_rows
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, warn_look_ahead
from grouptron.inference.online import ForecastRadii, OnlineCalibration, replay
from grouptron.inference.predictor import Predictor
from grouptron.inference.tracks import forecast_scene
from grouptron.model.regions import region_shapes
from grouptron.point_forecast import PointForecast
from grouptron.presets import describe_group_rule
from grouptron.viz.files import check_picture_path
from grouptron.viz.forecasts import Panel, animate_forecasts, plot_forecasts, tracks_around

POINT_LABELS = {"ml": "most likely", "ml-argmax": "argmax latent", "mean": "mean"}
"""How a panel's legend names a point forecast (``ml-topK``: most likely of top K)."""


def point_label(forecast: PointForecast) -> str:
    """The legend's name of a point forecast."""
    top = forecast.top if forecast.top != 1 else None
    return f"most likely of top {top}" if top else POINT_LABELS[forecast.name]


@dataclass(frozen=True)
class PlotRequest:
    """What to draw.

    Attributes:
        tracks: the track file and how to read it.
        out: the picture (``.png``, ...), or with ``until`` the animation (``.gif``, ``.mp4``).
        checkpoint: the model (a shipped name or a ``.safetensors`` file).
        compare: a second model drawn beside the first.
        frame: the frame to forecast from, in the file's own frame numbers (as ``predict``
            writes them; steps for a file in seconds); None: the frame with the most people.
        until: animate every step from ``frame`` to this frame.
        time_s: instead of ``frame``, the time in the file's own seconds.
        forecast: the point forecast drawn (a ``PointForecast`` or its name; None: the
            model's own).
        region: the probability of the drawn regions (None: none).
        samples: sampled futures drawn as thin lines (K).
        seed: of the samples.
        ids: write each person's id beside them.
        calibration: a ``grouptron calibrate`` file of ``checkpoint`` for the regions' radii
            (None: the one each checkpoint ships with, where it has one; False: none).
        online: the first model's regions take the radii an online calibration has in force
            at the frame drawn, the file replayed in time order from its start (strictly
            causal: only truths seen by then).
        device: where the network runs.
        progress: a progress bar over an animation's frames.
    """

    tracks: TrackFile
    out: Path
    checkpoint: str | Path = DEFAULT_CHECKPOINT
    compare: str | Path | None = None
    frame: int | None = None
    until: int | None = None
    time_s: float | None = None
    forecast: PointForecast | str | None = None
    region: float | None = 0.9
    samples: int = 0
    seed: int = 0
    ids: bool = False
    calibration: str | Path | bool | None = None
    online: bool = False
    device: str | torch.device = "cpu"
    progress: bool = False

    def __post_init__(self) -> None:
        if self.online and not self.region:
            raise GrouptronError("--online adapts the radii of the drawn regions: keep --region")
        if self.forecast is not None:
            object.__setattr__(self, "forecast", PointForecast.parse(self.forecast))


@dataclass(frozen=True)
class Plotted:
    """What was drawn: the table frames (one for a picture) and a line that says so."""

    frames: tuple[int, ...]
    summary: str


def plot_tracks(request: PlotRequest) -> Plotted:
    """Draw the forecasts of ``request.tracks`` at one frame (a panel per model), or each step
    from ``frame`` to ``until`` as an animation; every option is checked before the work."""
    until, frame = request.until, request.frame
    if until is not None and frame is not None and until <= frame:
        raise GrouptronError(f"--until {until} must come after --frame {frame}")
    check_picture_path(request.out, animation=until is not None, inputs=(request.tracks.path,))
    predictors = _predictors(request)
    for predictor in predictors:
        warn_look_ahead(predictor.source, predictor.config.data.derivatives)
    table, _ = read_track_file(request.tracks, predictors[0].config.data.frames_per_step)
    frame, until = _table_frames(request, table)
    if frame is None:  # the busiest frame (the middle one of equals): a telling picture
        frames, people = np.unique(table.frame, return_counts=True)
        busiest = frames[people == people.max()]
        frame = int(busiest[len(busiest) // 2])
        if until is not None and until <= frame:
            raise GrouptronError(f"--until {until} must come after --frame {frame}")
    _check_frame(request, table, frame)
    for predictor in predictors:  # forecast on the file's own frame grid
        data = dataclasses.replace(predictor.config.data, frames_per_step=table.frames_per_step)
        predictor.config = dataclasses.replace(predictor.config, data=data)
    online = _online_radii(predictors[0], table, request) if request.online else None
    if until is None:
        panels = _panels(request, predictors, table_rows(table), frame, online=online)
        plot_forecasts(panels, frame, request.out)
        return Plotted((frame,), f"wrote {request.out}: forecasts at {_file_time(table, frame)}")
    return _animate(request, predictors, table, frame, until)


def _animate(
    request: PlotRequest, predictors: list[Predictor], table: TrackTable, frame: int, until: int
) -> Plotted:
    """Every step from ``frame`` to ``until`` where someone can be forecast, animated."""
    data = predictors[0].config.data
    step = data.frames_per_step
    # Every frame reads only its own window: cut a long file to the frames drawn once, not
    # once per frame (central derivatives read two steps past the horizon's start).
    first = frame - max(p.window_frames for p in predictors)
    last = until + (data.horizon_steps + 2) * step
    rows = table_rows(table)  # (R, 4) frame, id, x, y
    rows = rows[(rows[:, 0] >= first) & (rows[:, 0] <= last)]
    present = set(rows[:, 0].astype(np.int64).tolist())
    wanted = tqdm(
        range(frame, until + 1, step),
        desc="forecasting",
        unit="frame",
        disable=not request.progress,
    )
    online = _online_radii(predictors[0], table, request) if request.online else None
    drawn = [
        (f, _panels(request, predictors, rows, f, required=False, online=online))
        for f in wanted
        if f in present
    ]
    drawn = [(f, panels) for f, panels in drawn if panels]
    if not drawn:
        raise GrouptronError(
            f"{request.tracks.path}: nobody between frames {frame} and {until} has "
            f"{predictors[0].min_points} observed steps"
        )
    animate_forecasts(drawn, request.out)
    frames = tuple(f for f, _ in drawn)
    summary = f"wrote {request.out}: {len(drawn)} frames from {frames[0]} to {frames[-1]}"
    return Plotted(frames, summary)


def _predictors(request: PlotRequest) -> list[Predictor]:
    """The predictor of ``checkpoint`` (with ``calibration``) and of ``compare``."""
    return [
        Predictor.from_checkpoint(
            c,
            forecast=request.forecast,
            device=request.device,
            check_speed=request.tracks.check_speed,  # the file was checked as it was read
            calibration=request.calibration if c == request.checkpoint else None,
            threads=None,  # a picture is no live loop: the threads the command was given
        )
        for c in (request.checkpoint, request.compare)
        if c
    ]


def _online_radii(
    predictor: Predictor, table: TrackTable, request: PlotRequest
) -> tuple[np.ndarray, np.ndarray]:
    """The file replayed from its start with online calibration (the predictor's radii to
    begin with): (F,) frames where forecasts were made and (F, H) the radii in force there."""
    assert request.region is not None
    config = predictor.config
    scene = build_scene(table, config.data, name=str(request.tracks.path))
    made = forecast_scene(
        predictor.model, config, scene, predictor.forecast, keep_distribution=True
    )
    assert made.distribution is not None
    state = OnlineCalibration.start(config.data.horizon_steps, predictor.calibration)
    seen = (table.frame.astype(np.int64), table.ped_id, table.pos_m)
    shapes = region_shapes(made.point, made.distribution)
    radii = replay(
        state,
        seen,
        (made.frames, made.ids, made.point, shapes),
        table.frames_per_step,
        (request.region,),
    )
    frames, first = np.unique(made.frames, return_index=True)
    return frames, radii.radii[first, 0]


def _table_frames(request: PlotRequest, table: TrackTable) -> tuple[int | None, int | None]:
    """``time_s`` (the file's seconds) and ``frame``/``until`` (the file's own frame numbers,
    as ``predict`` writes them) as the table's frames."""
    times, frame, until = table.times, request.frame, request.until
    if request.time_s is not None:
        if frame is not None or until is not None:
            raise GrouptronError("--time picks the frame: give --time or --frame (and --until)")
        return times.table_frame(request.time_s), None
    fps = times.file_fps
    if fps is None:  # a file in seconds has no frames: its frames are steps
        return frame, until
    return (
        None if frame is None else times.table_frame(frame / fps),
        None if until is None else times.table_frame(until / fps),
    )


def _file_time(table: TrackTable, frame: int) -> str:
    """``frame F (t = T s)`` in the file's own terms, for messages."""
    own = table.times.file_frames(np.array([frame]))
    seconds = float(table.times.seconds(np.array([frame]))[0])
    return f"frame {frame if own is None else int(own[0])} (t = {seconds:.2f} s)"


def _check_frame(request: PlotRequest, table: TrackTable, frame: int) -> None:
    """Refuse a frame off the file's frame grid or outside its frames."""
    if (frame - table.first_frame) % table.frames_per_step:
        raise GrouptronError(
            f"--frame {frame} is not on the {table.frames_per_step}-frame grid of "
            f"{request.tracks.path} (first frame {table.first_frame})"
        )
    last_frame = int(table.frame.max())
    if not table.first_frame <= frame <= last_frame:
        raise GrouptronError(
            f"--frame {frame} is outside the frames of {request.tracks.path} "
            f"({table.first_frame}-{last_frame})"
        )


def _panels(
    request: PlotRequest,
    predictors: list[Predictor],
    rows: np.ndarray,
    frame: int,
    *,
    required: bool = True,
    online: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[Panel]:
    """One panel per model at ``frame`` from (R, 4) ``frame, id, x, y`` ``rows`` (empty when
    nobody can be forecast and not ``required``); ``online``: the first model's radii in force
    per frame ((F,) frames, (F, H) radii at the drawn q)."""
    data = predictors[0].config.data
    panels = []
    for k, predictor in enumerate(predictors):
        forecast = predictor.predict(rows, frame, request.samples, request.seed, live=False)
        if online is not None and k == 0 and request.region:
            frames, radii = online
            at = max(int(np.searchsorted(frames, frame, "right")) - 1, 0)
            per_forecast = np.broadcast_to(radii[at], (len(forecast), 1, radii.shape[1]))
            calibration = ForecastRadii(np.array([request.region]), per_forecast)
            forecast = dataclasses.replace(forecast, calibration=calibration)
        if not len(forecast):
            if not required:
                return []
            raise GrouptronError(
                f"{request.tracks.path}: nobody at frame {frame} has {predictor.min_points} "
                "observed steps in a row; pick another --frame"
            )
        history, truth = tracks_around(
            rows,
            forecast.ids,
            frame,
            data.frames_per_step,
            before=data.history_steps - 1,
            after=data.horizon_steps,
        )
        config = predictor.config
        name = f"{config.model_name} ({config.data.derivatives})"
        label = point_label(predictor.forecast)
        rule = describe_group_rule(predictor.group_rule)
        panels.append(
            Panel(name, forecast, history, truth, label, rule, request.region, request.ids)
        )
    return panels
