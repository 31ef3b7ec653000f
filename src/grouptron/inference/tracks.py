"""Forecast every pedestrian of a track file at every step with a full observed history.

Predictions come back in the file's own coordinates and frame numbers, so they can be laid
over the input directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from tqdm import tqdm

from grouptron.config import ExperimentConfig
from grouptron.data.samples import SampleSet, scene_samples
from grouptron.data.scene import Scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import batches
from grouptron.evaluation.predict import predict_most_likely, predict_samples
from grouptron.groups.assign import SampleGroups, assign_groups
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import uses_groups

FORECAST_MODES = ("ml", "samples")


@dataclass(frozen=True)
class TrackForecast:
    """Forecasts of ``S`` (pedestrian, step) pairs.

    Attributes:
        frame: (S,) frame of the last observed position (the forecast's origin).
        ped_id: (S,) pedestrian id as written in the file.
        positions: (S, K, H, 2) predicted positions in the file's coordinates (metres);
            K = 1 for the most likely forecast.
        samples: the model inputs the forecasts were made from (``fut_rel_m`` is NaN where the
            file has no future position).
    """

    frame: np.ndarray
    ped_id: np.ndarray
    positions: np.ndarray
    samples: SampleSet

    def table(self) -> tuple[list[str], np.ndarray, list[str]]:
        """CSV header, (S * K * H, 5 or 6) rows ``frame, id, step, x, y[, sample]`` and their
        number formats; ``step`` k is the position k steps after ``frame``."""
        S, K, H, _ = self.positions.shape
        s, k, h = (a.ravel() for a in np.indices((S, K, H)))
        columns = [self.frame[s], self.ped_id[s], h + 1, *self.positions[s, k, h].T]
        header = ["frame", "id", "step", "x", "y"]
        formats = ["%d", "%.10g", "%d", "%.4f", "%.4f"]
        if K > 1:
            columns.append(k)
            header.append("sample")
            formats.append("%d")
        return header, np.stack([np.asarray(c, dtype=np.float64) for c in columns], 1), formats


def groups_for_model(samples: SampleSet, config: ExperimentConfig) -> SampleGroups | None:
    """The samples' groups when the model reads them (Grouptron), else None."""
    if not uses_groups(config):
        return None
    return assign_groups(samples, config.groups, config.data.position_scale_m)


@torch.inference_mode()
def forecast_scene(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    scene: Scene,
    mode: str = "ml",
    num_samples: int = 20,
    seed: int = 0,
    batch_size: int = 256,
    progress: bool = False,
) -> TrackForecast:
    """Forecast every (pedestrian, step) of ``scene`` whose last ``history_steps`` are observed.

    ``ml`` is the evaluator's most likely prediction; ``samples`` draws ``num_samples`` futures
    per pedestrian from the model (seeded). Grouptron clusters the neighbours first.
    """
    if mode not in FORECAST_MODES:
        raise GrouptronError(f"unknown forecast mode {mode!r}; choose from {FORECAST_MODES}")
    data = config.data
    samples = scene_samples(scene, data, data.history_steps, require_future=False)
    if not len(samples):
        raise GrouptronError(
            f"{scene.name}: no pedestrian has {data.history_steps} consecutive observed steps, "
            "so there is nothing to forecast"
        )
    groups = groups_for_model(samples, config)
    model.eval()
    generator = torch.Generator().manual_seed(seed)
    K = 1 if mode == "ml" else num_samples
    rel = np.empty((len(samples), K, data.horizon_steps, 2))  # (S, K, H, 2)
    total = -(-len(samples) // batch_size)
    for index, batch in tqdm(
        batches(samples, config, batch_size, groups), total=total, disable=not progress
    ):
        if mode == "ml":
            pred = predict_most_likely(model, batch, data.horizon_steps, data.dt_s)[:, None]
        else:
            pred = predict_samples(model, batch, data.horizon_steps, data.dt_s, K, generator)
        rel[index] = pred.double().numpy()
    origin_world = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (S, 2)
    return TrackForecast(
        frame=scene.first_frame + samples.step.astype(np.int64) * scene.frames_per_step,
        ped_id=scene.ped_id[samples.track],
        positions=rel + origin_world[:, None, None, :],
        samples=samples,
    )
