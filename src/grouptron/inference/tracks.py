"""Forecast every pedestrian of a track file at every step with a full observed history.

Predictions come back in the file's own coordinates and frame numbers, so they can be laid
over the input directly.
"""

from __future__ import annotations

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet, scene_samples
from grouptron.data.prepare.scene import Scene
from grouptron.errors import GrouptronError
from grouptron.inference.engine import EngineOptions
from grouptron.inference.forecast import Forecast
from grouptron.inference.learn_replay import Replay, forecast_by_version
from grouptron.model.factory import groups_for_model
from grouptron.model.forecaster import Forecaster
from grouptron.point_forecast import PointForecast


def _samples_to_forecast(
    scene: Scene, config: ExperimentConfig, min_points: int | None
) -> SampleSet:
    """Every (pedestrian, step) with ``min_points`` observed positions in a row up to it."""
    data = config.data
    min_points = data.history_steps if min_points is None else min_points
    if not 2 <= min_points <= data.history_steps:
        raise GrouptronError(f"min_points must be from 2 to {data.history_steps}, not {min_points}")
    samples = scene_samples(scene, data, min_points, require_future=False)
    if not len(samples):
        raise GrouptronError(
            f"{scene.name}: no pedestrian has {min_points} consecutive observed steps, "
            "so there is nothing to forecast"
        )
    return samples


def forecast_scene(  # noqa: PLR0913 - the forecast options, all keyword-only
    model: Forecaster,
    config: ExperimentConfig,
    scene: Scene,
    forecast: PointForecast | str = "ml",
    *,
    num_samples: int = 0,
    seed: int = 0,
    batch_size: int = 256,
    progress: bool = False,
    min_points: int | None = None,
    device: torch.device | str = "cpu",
    keep_distribution: bool = False,
    replay: Replay | None = None,
) -> Forecast:
    """Forecast every (pedestrian, step) of ``scene`` with ``min_points`` observed positions in
    a row up to it (default ``history_steps``: the samples the evaluator scores; 2 at least).

    The point forecast is ``forecast``'s (:class:`PointForecast`); ``samples`` adds
    ``num_samples`` futures per pedestrian drawn from the model (seeded). Grouptron clusters
    the neighbours first. The forecasts carry no mixture of all latent values and no
    scene-wide groups (``Predictor`` gives those); ``keep_distribution`` keeps the Gaussians
    the point forecast was made from, for ``Forecast.regions`` (about 1 KB per forecast and
    latent value). With a ``replay`` of online learning, each forecast is made with the
    weights the replay had in use at its step.
    """
    forecast = PointForecast.parse(forecast)
    samples = _samples_to_forecast(scene, config, min_points)
    options = EngineOptions(
        distribution=keep_distribution,
        num_samples=num_samples,
        seed=seed,
        batch_size=batch_size,
        device=device,
        progress=progress,
    )
    groups = groups_for_model(samples, config)
    made = forecast_by_version(replay, model.to(device), config, samples, forecast, groups, options)
    origin_world = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (S, 2)
    frames = scene.first_frame + samples.step.astype(np.int64) * scene.frames_per_step
    return Forecast(
        frame=int(frames[0]) if len(np.unique(frames)) == 1 else None,
        frames=frames,
        ids=scene.ped_id[samples.track],
        point=made.point + origin_world[:, None, :],
        samples=None if made.samples is None else made.samples + origin_world[:, None, None, :],
        distribution=None if made.distribution is None else made.distribution.moved(origin_world),
        observed_points=samples.hist_mask.sum(axis=1),
        filled_points=np.zeros(len(samples), dtype=np.int64),
    )
