"""Forecasts made elsewhere, scored on the very samples a checkpoint is scored on: each sample
found in a forecast file by its recording's own frame number and person id, then the same
metrics and modes (a point forecast as ``ml``, best-of-K from the samples given)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from grouptron.data.formats.forecast_file import ForecastRows
from grouptron.data.prepare.samples import SampleSet
from grouptron.data.prepare.scene import Scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, forecast_scores
from grouptron.point_forecast import best_of_samples, is_point_forecast


def sample_keys(scenes: Sequence[Scene], samples: SampleSet) -> tuple[np.ndarray, np.ndarray]:
    """(S,) every sample's forecast time as its recording's own frame number and (S,) its
    person's id as written there (``scenes`` in the order of ``samples.scene_index``)."""
    first = np.array([s.first_frame for s in scenes])[samples.scene_index]
    per_step = np.array([s.frames_per_step for s in scenes])[samples.scene_index]
    ids = np.concatenate([s.ped_id for s in scenes])  # (A_all,) tracks of all scenes in order
    offsets = np.cumsum([0] + [len(s.ped_id) for s in scenes])[:-1]
    return first + samples.step * per_step, ids[offsets[samples.scene_index] + samples.track]


def positions_of_samples(
    rows: ForecastRows, frames: np.ndarray, ids: np.ndarray, horizon: int, source: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """(S, K, H, 2) the file's forecasts of the samples keyed by (S,) ``frames`` and ``ids``
    (K = 1 for point forecasts, else the file's sampled futures in sample order; NaN where
    missing), and (S,) whether every position of a sample is there."""
    keys = np.concatenate([np.stack([rows.frame, rows.ids], 1), np.stack([frames, ids], 1)])
    codes = np.unique(keys, axis=0, return_inverse=True)[1].ravel()
    row_code, sample_code = codes[: len(rows.frame)], codes[len(rows.frame) :]
    sample = np.zeros(len(rows.frame), np.int64) if rows.sample is None else rows.sample
    numbers, k = np.unique(sample, return_inverse=True)
    table = np.full((codes.max() + 1, len(numbers), horizon, 2), np.nan)
    inside = rows.step <= horizon
    cells = np.stack([row_code, k.ravel(), rows.step], 1)[inside]  # (R', 3) one per position
    if len(np.unique(cells, axis=0)) < len(cells):
        raise GrouptronError(
            f"{source}: a position given twice (the same frame, id, sample and step)"
        )
    table[row_code[inside], k.ravel()[inside], rows.step[inside] - 1] = rows.xy_m[inside]
    positions = table[sample_code]
    found = np.asarray(~np.isnan(positions).any(axis=(1, 2, 3)))
    return positions, found


def default_modes(positions: np.ndarray) -> tuple[str, ...]:
    """``ml`` for a file of point forecasts, best-of-20 (or of all, if fewer) for samples."""
    K = positions.shape[1]
    return ("ml",) if K == 1 else (f"best-of-{min(K, 20)}",)


def file_scores(
    positions: np.ndarray, samples: SampleSet, modes: Sequence[str], source: str
) -> list[SampleScores]:
    """Per-sample scores of (S, K, H, 2) forecasts (relative to each sample's present) against
    the ``samples``' truths in each mode: a
    point forecast's name scores a file of point forecasts, ``best-of-K`` the first K samples
    of each forecast; anything else is refused naming ``source``."""
    K = positions.shape[1]
    scored = []
    for mode in modes:
        best_of = best_of_samples(mode)
        if is_point_forecast(mode) and K == 1:
            scored.append(forecast_scores(mode, positions[:, 0], samples))
        elif best_of is not None and best_of <= K > 1:
            scored.append(forecast_scores(mode, positions[:, :best_of], samples))
        else:
            has = "one point forecast" if K == 1 else f"{K} sampled futures"
            raise GrouptronError(
                f"{source} holds {has} per forecast; --mode {mode} cannot be scored from it "
                f"(point forecasts: ml; samples: best-of-K with K at most {K})"
            )
    return scored
