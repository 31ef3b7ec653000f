"""Evaluate a trained model on a sample set: ML, ML-argmax, best-of-20 and KDE NLL."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import torch
from tqdm import tqdm

from grouptron.config import ExperimentConfig
from grouptron.data.samples import SampleSet
from grouptron.evaluation import metrics
from grouptron.evaluation.predict import (
    predict_argmax_latent,
    predict_most_likely,
    predict_samples,
)
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import Batch, make_batch
from grouptron.model.cvae import TrajectronCVAE

MODES = ("ml", "ml-argmax", "best-of-20", "nll")
BEST_OF = 20
NLL_SAMPLES = 2000


@dataclass(frozen=True)
class ModeScores:
    """Mean scores of one evaluation mode over ``samples`` samples (NaN where not defined)."""

    mode: str
    samples: int
    ade: float
    fde: float
    nll: float = float("nan")
    nll_undefined: int = 0
    """Samples whose KDE could not be built (all predictions identical at some step)."""


def batches(
    samples: SampleSet,
    config: ExperimentConfig,
    batch_size: int,
    groups: SampleGroups | None = None,
) -> Iterator[tuple[np.ndarray, Batch]]:
    """Consecutive batches of the whole set, in order, without augmentation."""
    for start in range(0, len(samples), batch_size):
        index = np.arange(start, min(start + batch_size, len(samples)))
        yield index, make_batch(samples, index, config.data, groups=groups)


@torch.inference_mode()
def evaluate_model(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    modes: tuple[str, ...] = ("ml",),
    batch_size: int = 256,
    seed: int = 0,
    progress: bool = False,
    groups: SampleGroups | None = None,
    device: torch.device | str = "cpu",
) -> list[ModeScores]:
    """Mean ADE/FDE (metres) of each requested mode, and the KDE NLL for ``"nll"``.

    Sampling modes use a generator seeded with ``seed``, so results are reproducible.
    Grouptron needs the samples' ``groups``. The model must already be on ``device``.
    """
    unknown = set(modes) - set(MODES)
    if unknown:
        raise ValueError(f"unknown evaluation modes {sorted(unknown)}")
    model.eval()
    horizon, dt = config.data.horizon_steps, config.data.dt_s
    generator = torch.Generator(device=device).manual_seed(seed)
    sums = {mode: np.zeros(3) for mode in modes}  # ade, fde, nll sums
    undefined = 0
    nll_batch = max(1, batch_size // 64)
    for mode in modes:
        size = nll_batch if mode == "nll" else batch_size
        iterator = batches(samples, config, size, groups)
        total = -(-len(samples) // size)
        for _, batch in tqdm(iterator, total=total, desc=mode, disable=not progress, leave=False):
            batch = batch.to(device)
            truth = batch.fut_rel_m.double().cpu().numpy()
            if mode == "ml":
                pred = predict_most_likely(model, batch, horizon, dt).double().cpu().numpy()
            elif mode == "ml-argmax":
                pred = predict_argmax_latent(model, batch, horizon, dt).double().cpu().numpy()
            else:
                k = BEST_OF if mode == "best-of-20" else NLL_SAMPLES
                draws = predict_samples(model, batch, horizon, dt, k, generator)
                draws_np = draws.double().cpu().numpy()  # (B, K, H, 2)
                if mode == "best-of-20":
                    sums[mode] += [
                        metrics.min_ade_k(draws_np, truth).sum(),
                        metrics.min_fde_k(draws_np, truth).sum(),
                        0.0,
                    ]
                    continue
                nll = metrics.kde_nll(draws_np, truth)
                undefined += int(np.isnan(nll).sum())
                sums[mode] += [np.nan, np.nan, np.nansum(nll)]
                continue
            sums[mode] += [metrics.ade(pred, truth).sum(), metrics.fde(pred, truth).sum(), 0.0]
    results = []
    count = len(samples)
    for mode in modes:
        ade_sum, fde_sum, nll_sum = sums[mode]
        if mode == "nll":
            defined = count - undefined
            results.append(
                ModeScores(
                    mode,
                    count,
                    float("nan"),
                    float("nan"),
                    nll_sum / defined if defined else float("nan"),
                    undefined,
                )
            )
        else:
            results.append(ModeScores(mode, count, ade_sum / count, fde_sum / count))
    return results
