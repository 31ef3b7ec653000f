"""Evaluate a trained model on a sample set: ML, ML-argmax, best-of-20 and KDE NLL."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from tqdm import tqdm

from grouptron import constants
from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import ExperimentConfig
from grouptron.data.samples import SampleSet
from grouptron.evaluation import metrics
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import batches
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.predict import (
    POINT_FORECASTS,
    Ablation,
    decode_every_latent,
    mixture_mean_positions,
    most_likely_positions,
    predict_samples,
)

MODES = constants.EVALUATION_MODES
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


@dataclass(frozen=True)
class SampleScores:
    """Per-sample scores of one mode: (S,) arrays, NaN where the mode does not define them."""

    mode: str
    ade: np.ndarray
    fde: np.ndarray
    nll: np.ndarray

    def summary(self, keep: np.ndarray | None = None) -> ModeScores:
        """Means over all samples, or over the samples where the (S,) mask ``keep`` is true."""
        ade, fde, nll = (v if keep is None else v[keep] for v in (self.ade, self.fde, self.nll))
        count = len(ade)
        if self.mode != "nll":
            return ModeScores(self.mode, count, _mean(ade), _mean(fde))
        undefined = int(np.isnan(nll).sum())
        defined = nll[~np.isnan(nll)]
        return ModeScores(self.mode, count, math.nan, math.nan, _mean(defined), undefined)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else math.nan


# One loop over modes and batches, so that point forecasts, best-of-20 and the NLL read the
# very same batches (their per-sample scores are paired later).
@torch.inference_mode()
def score_samples(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    modes: tuple[str, ...] = ("ml",),
    *,
    batch_size: int = 256,
    seed: int = 0,
    progress: bool = False,
    groups: SampleGroups | None = None,
    device: torch.device | str = "cpu",
    ablate: Ablation = (),
) -> list[SampleScores]:
    """Per-sample ADE/FDE (metres) of each requested mode, and the KDE NLL for ``"nll"``.

    Every sample is predicted independently of its batch, so means over a subset of these
    scores equal an evaluation of that subset (UNIV-N is scored this way). Each sampling mode
    starts its own generator from ``seed``, so results are reproducible and a mode scores the
    same whichever other modes are asked with it. Grouptron needs the samples' ``groups``. The
    model must already be on ``device``.
    """
    unknown = set(modes) - set(MODES)
    if unknown:
        raise ValueError(f"unknown evaluation modes {sorted(unknown)}")
    model.eval()
    horizon, dt = config.data.horizon_steps, config.data.dt_s
    count = len(samples)
    nll_batch = max(1, batch_size // 64)
    results: dict[str, SampleScores] = {}
    if all(mode in modes for mode in SHARED_DECODE):
        results = _score_shared_decode(
            model, config, samples, batch_size, groups, device, ablate, progress
        )
    for mode in (m for m in modes if m not in results):
        ade, fde, nll = (np.full(count, np.nan) for _ in range(3))
        generator = torch.Generator(device=device).manual_seed(seed)  # per mode: see above
        size = nll_batch if mode == "nll" else batch_size
        iterator = batches(samples, config, size, groups)
        total = -(-count // size)
        for index, batch in tqdm(
            iterator, total=total, desc=mode, disable=not progress, leave=False
        ):
            batch = batch.to(device)
            truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
            if mode in POINT_FORECASTS:
                predict = POINT_FORECASTS[mode]
                pred = predict(model, batch, horizon, dt, ablate).double().cpu().numpy()
                ade[index], fde[index] = metrics.ade(pred, truth), metrics.fde(pred, truth)
                continue
            k = BEST_OF if mode == "best-of-20" else NLL_SAMPLES
            draws = predict_samples(
                model, batch, horizon, dt, num_samples=k, generator=generator, ablate=ablate
            )
            draws_np = draws.double().cpu().numpy()  # (B, K, H, 2)
            if mode == "best-of-20":
                ade[index] = metrics.min_ade_k(draws_np, truth)
                fde[index] = metrics.min_fde_k(draws_np, truth)
            else:
                nll[index] = metrics.kde_nll(draws_np, truth)
        results[mode] = SampleScores(mode, ade, fde, nll)
    return [results[mode] for mode in modes]


SHARED_DECODE = ("ml", "mean")
"""Point forecasts read from one decode of every latent value (following its means): scored
together, that decode runs once per batch instead of once per forecast, with the same numbers."""


def _score_shared_decode(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    batch_size: int,
    groups: SampleGroups | None,
    device: torch.device | str,
    ablate: Ablation,
    progress: bool,
) -> dict[str, SampleScores]:
    """The ``SHARED_DECODE`` forecasts' per-sample ADE/FDE, in one pass over the batches."""
    horizon, dt, count = config.data.horizon_steps, config.data.dt_s, len(samples)
    scores = {mode: (np.full(count, np.nan), np.full(count, np.nan)) for mode in SHARED_DECODE}
    iterator = batches(samples, config, batch_size, groups)
    total = -(-count // batch_size)
    for index, batch in tqdm(
        iterator, total=total, desc="+".join(SHARED_DECODE), disable=not progress, leave=False
    ):
        batch = batch.to(device)
        truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
        encoding, velocity = decode_every_latent(model, batch, horizon, ablate)
        predictions = {
            "ml": most_likely_positions(encoding, velocity, horizon, dt),
            "mean": mixture_mean_positions(encoding, velocity, dt),
        }
        for mode, (ade, fde) in scores.items():
            pred = predictions[mode].double().cpu().numpy()  # (B, H, 2)
            ade[index], fde[index] = metrics.ade(pred, truth), metrics.fde(pred, truth)
    nan = np.full(count, np.nan)
    return {mode: SampleScores(mode, ade, fde, nan) for mode, (ade, fde) in scores.items()}


def evaluate_model(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    modes: tuple[str, ...] = ("ml",),
    *,
    batch_size: int = 256,
    seed: int = 0,
    progress: bool = False,
    groups: SampleGroups | None = None,
    device: torch.device | str = "cpu",
    ablate: Ablation = (),
) -> list[ModeScores]:
    """Mean ADE/FDE (metres) of each requested mode over ``samples`` (see ``score_samples``)."""
    per_sample = score_samples(
        model,
        config,
        samples,
        modes,
        batch_size=batch_size,
        seed=seed,
        progress=progress,
        groups=groups,
        device=device,
        ablate=ablate,
    )
    return [scores.summary() for scores in per_sample]


def constant_velocity_scores(samples: SampleSet, horizon_steps: int) -> SampleScores:
    """Per-sample ADE/FDE (metres) of constant velocity, the one baseline every table shows."""
    pred = constant_velocity(samples.hist_rel_m.astype(np.float64), horizon_steps)
    truth = samples.fut_rel_m.astype(np.float64)
    nan = np.full(len(samples), np.nan)
    return SampleScores("ml", metrics.ade(pred, truth), metrics.fde(pred, truth), nan)
