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
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation import metrics
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import batches
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.predict import (
    Ablation,
    decode,
    mixture_mean_positions,
    predict_point,
    predict_samples,
)
from grouptron.point_forecast import PointForecast, is_evaluation_mode, is_point_forecast

MODES = constants.EVALUATION_MODES
BEST_OF = 20
NLL_SAMPLES = 2000


@dataclass(frozen=True)
class ModeScores:
    """Mean scores of one evaluation mode over ``samples`` samples.

    Attributes:
        means: mean of each metric by name (the registered ones; ``nll`` for the NLL mode).
        nll_undefined: samples whose KDE could not be built (all draws identical at some step).
    """

    mode: str
    samples: int
    means: dict[str, float]
    nll_undefined: int = 0

    @property
    def ade(self) -> float:
        """Mean ADE in metres; NaN where this mode does not score it."""
        return self.means.get("ade", math.nan)

    @property
    def fde(self) -> float:
        """Mean FDE in metres; NaN where this mode does not score it."""
        return self.means.get("fde", math.nan)

    @property
    def nll(self) -> float:
        """Mean KDE NLL in nats; NaN outside the ``nll`` mode."""
        return self.means.get(metrics.NLL, math.nan)


@dataclass(frozen=True)
class SampleScores:
    """Per-sample scores of one mode: metric name -> (S,) array (NaN where not scored).

    Point forecasts and best-of-20 carry every registered metric
    (:data:`grouptron.evaluation.metrics.METRICS`); the ``nll`` mode carries ``nll`` alone.
    """

    mode: str
    values: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(next(iter(self.values.values())))

    def get(self, name: str) -> np.ndarray:
        """(S,) one metric's scores; all NaN where this mode does not define it."""
        found = self.values.get(name)
        return found if found is not None else np.full(len(self), np.nan)

    @property
    def ade(self) -> np.ndarray:
        """(S,) ADE of every sample in metres; NaN where not scored."""
        return self.get("ade")

    @property
    def fde(self) -> np.ndarray:
        """(S,) FDE of every sample in metres; NaN where not scored."""
        return self.get("fde")

    @property
    def nll(self) -> np.ndarray:
        """(S,) KDE NLL of every sample in nats; NaN where not scored."""
        return self.get(metrics.NLL)

    def subset(self, keep: np.ndarray) -> SampleScores:
        """The scores of the samples where the (S,) mask ``keep`` is true."""
        return SampleScores(self.mode, {k: v[keep] for k, v in self.values.items()})

    def summary(self, keep: np.ndarray | None = None) -> ModeScores:
        """Means over all samples, or over the samples where the (S,) mask ``keep`` is true."""
        kept = self if keep is None else self.subset(keep)
        count = len(kept)
        if self.mode != metrics.NLL:
            return ModeScores(self.mode, count, {k: _mean(v) for k, v in kept.values.items()})
        nll = kept.nll
        undefined = int(np.isnan(nll).sum())
        return ModeScores(self.mode, count, {metrics.NLL: _mean(nll[~np.isnan(nll)])}, undefined)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else math.nan


# One loop over modes and batches, so that point forecasts, best-of-20 and the NLL read the
# very same batches (their per-sample scores are paired later).
@torch.inference_mode()
def score_samples(  # noqa: PLR0913 - the scoring options, all keyword-only
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
    unknown = {m for m in modes if not is_evaluation_mode(m)}
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
        values: dict[str, np.ndarray] = {}
        generator = torch.Generator(device=device).manual_seed(seed)  # per mode: see above
        size = nll_batch if mode == "nll" else batch_size
        iterator = batches(samples, config, size, groups)
        total = -(-count // size)
        for index, batch in tqdm(
            iterator, total=total, desc=mode, disable=not progress, leave=False
        ):
            batch = batch.to(device)
            truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
            if is_point_forecast(mode):
                named = PointForecast.parse(mode)
                point = predict_point(model, batch, named, horizon, dt, ablate)
                _store(values, index, count, metrics.point_scores(point.double().numpy(), truth))
                continue
            k = BEST_OF if mode == "best-of-20" else NLL_SAMPLES
            draws = predict_samples(
                model, batch, horizon, dt, num_samples=k, generator=generator, ablate=ablate
            )
            draws_np = draws.double().cpu().numpy()  # (B, K, H, 2)
            if mode == "best-of-20":
                _store(values, index, count, metrics.best_of_scores(draws_np, truth))
            else:
                _store(values, index, count, {metrics.NLL: metrics.kde_nll(draws_np, truth)})
        results[mode] = SampleScores(mode, _complete(values, count))
    return [results[mode] for mode in modes]


def _store(
    values: dict[str, np.ndarray], index: np.ndarray, count: int, batch: dict[str, np.ndarray]
) -> None:
    """Write one batch's (B,) scores per metric into the (S,) arrays at ``index``."""
    for name, scores in batch.items():
        values.setdefault(name, np.full(count, np.nan))[index] = scores


def _complete(values: dict[str, np.ndarray], count: int) -> dict[str, np.ndarray]:
    """The scores of an empty sample set still name their metrics."""
    return values or {name: np.full(count, np.nan) for name in metrics.METRICS}


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
    scores: dict[str, dict[str, np.ndarray]] = {mode: {} for mode in SHARED_DECODE}
    iterator = batches(samples, config, batch_size, groups)
    total = -(-count // batch_size)
    for index, batch in tqdm(
        iterator, total=total, desc="+".join(SHARED_DECODE), disable=not progress, leave=False
    ):
        batch = batch.to(device)
        truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
        decoded = decode(model, batch, PointForecast("ml"), horizon, dt, ablate=ablate)
        predictions = {  # ml decodes all Z, whose weighted mean is the mean forecast
            "ml": decoded.point,
            "mean": mixture_mean_positions(decoded.encoding, decoded.velocity, dt),
        }
        for mode, values in scores.items():
            pred = predictions[mode].double().cpu().numpy()  # (B, H, 2)
            _store(values, index, count, metrics.point_scores(pred, truth))
    return {mode: SampleScores(mode, _complete(v, count)) for mode, v in scores.items()}


def evaluate_model(  # noqa: PLR0913 - score_samples's options, all keyword-only
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
    return SampleScores("ml", metrics.point_scores(pred, truth))
