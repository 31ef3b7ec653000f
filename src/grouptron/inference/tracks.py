"""Forecast every pedestrian of a track file at every step with a full observed history.

Predictions come back in the file's own coordinates and frame numbers, so they can be laid
over the input directly.
"""

from __future__ import annotations

import numpy as np
import torch
from tqdm import tqdm

from grouptron import constants
from grouptron.config import ExperimentConfig
from grouptron.data.samples import SampleSet, scene_samples
from grouptron.data.scene import Scene
from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.model.batch import batches
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import POINT_FORECASTS, predict_most_likely, predict_samples

FORECAST_MODES = constants.FORECAST_MODES


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


@torch.inference_mode()
def forecast_scene(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    scene: Scene,
    mode: str = "ml",
    *,
    num_samples: int = 20,
    seed: int = 0,
    batch_size: int = 256,
    progress: bool = False,
    min_points: int | None = None,
    device: torch.device | str = "cpu",
) -> Forecast:
    """Forecast every (pedestrian, step) of ``scene`` with ``min_points`` observed positions in
    a row up to it (default ``history_steps``: the samples the evaluator scores; 2 at least).

    The point forecast (in ``most_likely``) is ``mode``'s (:data:`POINT_FORECASTS`: ``ml`` the
    evaluator's most likely, ``ml-argmax``, ``mean``); ``samples`` adds ``num_samples``
    futures per pedestrian drawn from the model (seeded) to the ``ml`` one. Grouptron clusters
    the neighbours first. The forecasts carry no mixture and no scene-wide groups
    (``Predictor`` gives those).
    """
    if mode not in FORECAST_MODES:
        raise GrouptronError(f"unknown forecast mode {mode!r}; choose from {FORECAST_MODES}")
    data = config.data
    samples = _samples_to_forecast(scene, config, min_points)
    groups = groups_for_model(samples, config)
    model.eval().to(device)
    generator = torch.Generator(device=device).manual_seed(seed)
    K, H = (num_samples if mode == "samples" else 0), data.horizon_steps
    most_likely = np.empty((len(samples), H, 2))  # (S, H, 2)
    drawn = np.empty((len(samples), K, H, 2))  # (S, K, H, 2)
    total = -(-len(samples) // batch_size)
    for index, batch in tqdm(
        batches(samples, config, batch_size, groups), total=total, disable=not progress
    ):
        batch = batch.to(device)
        point = POINT_FORECASTS.get(mode, predict_most_likely)  # samples: with the ml one
        most_likely[index] = point(model, batch, H, data.dt_s, ()).double().cpu().numpy()
        if K:
            pred = predict_samples(model, batch, H, data.dt_s, num_samples=K, generator=generator)
            drawn[index] = pred.double().cpu().numpy()
    origin_world = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (S, 2)
    frames = scene.first_frame + samples.step.astype(np.int64) * scene.frames_per_step
    return Forecast(
        frame=int(frames[0]) if len(np.unique(frames)) == 1 else None,
        frames=frames,
        ids=scene.ped_id[samples.track],
        most_likely=most_likely + origin_world[:, None, :],
        samples=drawn + origin_world[:, None, None, :] if K else None,
        mixture_log_weights=None,
        mixture_means=None,
        mixture_covariances=None,
        group=None,
        observed_points=samples.hist_mask.sum(axis=1),
        filled_points=np.zeros(len(samples), dtype=np.int64),
    )
