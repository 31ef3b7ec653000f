"""Forecast every pedestrian of a track file at every step with a full observed history.

Predictions come back in the file's own coordinates and frame numbers, so they can be laid
over the input directly.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import torch
from tqdm import tqdm

from grouptron import constants
from grouptron.config import ExperimentConfig
from grouptron.constants import is_point_forecast
from grouptron.data.samples import SampleSet, scene_samples
from grouptron.data.scene import Scene
from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.model.batch import Batch, batches
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import (
    point_forecast,
    point_forecast_and_gaussians,
    predict_samples,
)

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
    keep_distribution: bool = False,
) -> Forecast:
    """Forecast every (pedestrian, step) of ``scene`` with ``min_points`` observed positions in
    a row up to it (default ``history_steps``: the samples the evaluator scores; 2 at least).

    The point forecast (in ``most_likely``) is ``mode``'s (:func:`point_forecast`: ``ml`` the
    evaluator's most likely, ``ml-argmax``, ``mean``, ``ml-topK``); ``samples`` adds ``num_samples``
    futures per pedestrian drawn from the model (seeded) to the ``ml`` one. Grouptron clusters
    the neighbours first. The forecasts carry no mixture and no scene-wide groups
    (``Predictor`` gives those); ``keep_distribution`` keeps the Gaussians the point forecast
    was made from, for ``Forecast.regions`` (about 1 KB per forecast and latent value).
    """
    if mode != "samples" and not is_point_forecast(mode):
        raise GrouptronError(
            f"unknown forecast mode {mode!r}; choose from {', '.join(FORECAST_MODES)} or ml-topK"
        )
    samples = _samples_to_forecast(scene, config, min_points)
    groups = groups_for_model(samples, config)
    model.eval().to(device)
    K = num_samples if mode == "samples" else 0
    loader = batches(samples, config, batch_size, groups)
    total = -(-len(samples) // batch_size)
    batched = tqdm(loader, total=total, disable=not progress)
    point_mode = "ml" if mode == "samples" else mode  # samples: with the ml one
    most_likely, drawn, kept = _decode_batches(
        model, config, batched, len(samples), point_mode, K, seed, device, keep_distribution
    )
    origin_world = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (S, 2)
    log_weights, means, covariances = (None, None, None) if kept is None else kept
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
        point_log_weights=log_weights,
        point_means=None if means is None else means + origin_world[:, None, None, :],
        point_covariances=covariances,
    )


def _decode_batches(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    batched: Iterable[tuple[np.ndarray, Batch]],
    count: int,
    point_mode: str,
    num_samples: int,
    seed: int,
    device: torch.device | str,
    keep_distribution: bool,
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
    """(S, H, 2) point forecasts, (S, K, H, 2) samples and, if kept, the point forecast's
    (S, M) log weights, (S, M, H, 2) means and (S, M, H, 2, 2) covariances, relative to now."""
    H, dt = config.data.horizon_steps, config.data.dt_s
    generator = torch.Generator(device=device).manual_seed(seed)
    most_likely = np.empty((count, H, 2))
    drawn = np.empty((count, num_samples, H, 2))
    kept: list[np.ndarray] = []
    for index, batch in batched:
        batch = batch.to(device)
        if keep_distribution:
            point, own = point_forecast_and_gaussians(model, batch, H, dt, point_mode)
            for i, part in enumerate(own.as_arrays(np.zeros((len(point), 2)))):
                if len(kept) <= i:  # M is known once the first batch is decoded
                    kept.append(np.empty((count, *part.shape[1:])))
                kept[i][index] = part
        else:
            point = point_forecast(point_mode)(model, batch, H, dt, ())
        most_likely[index] = point.double().cpu().numpy()
        if num_samples:
            pred = predict_samples(
                model, batch, H, dt, num_samples=num_samples, generator=generator
            )
            drawn[index] = pred.double().cpu().numpy()
    distribution = (kept[0], kept[1], kept[2]) if kept else None
    return most_likely, drawn, distribution
