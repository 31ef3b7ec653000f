"""Evaluate a trained model on a sample set: ML, ML-argmax, best-of-K and KDE NLL, the
displacement error of every forecast step, and the prediction regions of point forecasts
(coverage and area per step)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch
from tqdm import tqdm

from grouptron import constants
from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation import metrics
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.evaluation.scene_metrics import SceneForecasts, moment_ids
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import batches
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.forecaster import Forecaster, PointResult
from grouptron.model.mixture import Mixture
from grouptron.model.predict import Ablation, Decoded, mixture_mean_positions
from grouptron.point_forecast import (
    PointForecast,
    best_of_samples,
    is_evaluation_mode,
    is_point_forecast,
)

MODES = constants.EVALUATION_MODES
BEST_OF = 20
"""K of the named best-of mode (``best-of-K`` scores any K)."""
NLL_SAMPLES = 2000


@dataclass(frozen=True)
class ModeScores:
    """Mean scores of one evaluation mode over ``samples`` samples.

    Attributes:
        means: mean of each metric by name (the registered ones; ``nll`` for the NLL mode).
        nll_undefined: samples whose KDE could not be built (all draws identical at some step).
        step_means: per metric scored per step (the displacement error, the region metrics),
            its (H,) means.
    """

    mode: str
    samples: int
    means: dict[str, float]
    nll_undefined: int = 0
    step_means: dict[str, tuple[float, ...]] = field(default_factory=dict)

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

    Point forecasts and best-of-K carry every registered metric
    (:data:`grouptron.evaluation.metrics.METRICS`) and, in ``per_step``, the (S, H)
    displacement error of every step (``metrics.DISPLACEMENT``); the ``nll`` mode carries
    ``nll`` alone. Point forecasts scored with regions carry the region metrics too:
    ``per_step`` holds their (S, H) scores and ``values`` each sample's mean over the H steps.
    """

    mode: str
    values: dict[str, np.ndarray]
    per_step: dict[str, np.ndarray] = field(default_factory=dict)

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
        return SampleScores(
            self.mode,
            {k: v[keep] for k, v in self.values.items()},
            {k: v[keep] for k, v in self.per_step.items()},
        )

    def summary(self, keep: np.ndarray | None = None) -> ModeScores:
        """Means over all samples, or over the samples where the (S,) mask ``keep`` is true."""
        kept = self if keep is None else self.subset(keep)
        count = len(kept)
        if self.mode != metrics.NLL:
            means = {k: _mean(v) for k, v in kept.values.items()}
            steps = {k: _step_means(v) for k, v in kept.per_step.items()}
            return ModeScores(self.mode, count, means, step_means=steps)
        nll = kept.nll
        undefined = int(np.isnan(nll).sum())
        return ModeScores(self.mode, count, {metrics.NLL: _mean(nll[~np.isnan(nll)])}, undefined)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else math.nan


def _step_means(values: np.ndarray) -> tuple[float, ...]:
    """(S, H) scores -> their H means over the samples (NaN without samples)."""
    if not len(values):
        return tuple(math.nan for _ in range(values.shape[1]))
    return tuple(float(v) for v in values.mean(axis=0))


# One loop over modes and batches, so that point forecasts, best-of-K and the NLL read the
# very same batches (their per-sample scores are paired later).
@torch.inference_mode()
def score_samples(  # noqa: PLR0913 - the scoring options, all keyword-only
    model: Forecaster,
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
    regions: RegionScoring | None = None,
) -> list[SampleScores]:
    """Per-sample ADE/FDE (metres) and every registered metric of each requested mode
    (``best-of-K``: the best of K sampled futures), the displacement error of every step, and
    the KDE NLL for ``"nll"``; with ``regions``, every point forecast's region metrics
    (coverage, area) per step too.

    Every sample is predicted independently of its batch, so means over a subset of these
    scores equal an evaluation of that subset (UNIV-N is scored this way); a scene-level
    metric's are the exception: its "others" are those of the whole set. Each sampling mode
    starts its own generator from ``seed``, so results are reproducible and a mode scores the
    same whichever other modes are asked with it. Grouptron needs the samples' ``groups``. The
    model must already be on ``device``.
    """
    unknown = {m for m in modes if not is_evaluation_mode(m)}
    if unknown:
        raise ValueError(f"unknown evaluation modes {sorted(unknown)}")
    model.eval()
    results: dict[str, SampleScores] = {}
    if all(mode in modes for mode in SHARED_DECODE) and isinstance(model, TrajectronCVAE):
        results = _score_shared_decode(
            model,
            config,
            samples,
            batch_size=batch_size,
            groups=groups,
            device=device,
            ablate=ablate,
            progress=progress,
            regions=regions,
        )
    for mode in (m for m in modes if m not in results):
        results[mode] = _mode_scores(
            model,
            config,
            samples,
            mode,
            batch_size=max(1, batch_size // 64) if mode == metrics.NLL else batch_size,
            seed=seed,
            progress=progress,
            groups=groups,
            device=device,
            ablate=ablate,
            regions=regions,
        )
    return [results[mode] for mode in modes]


def _mode_scores(  # noqa: PLR0913 - score_samples's options, all keyword-only
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    mode: str,
    *,
    batch_size: int,
    seed: int,
    progress: bool,
    groups: SampleGroups | None,
    device: torch.device | str,
    ablate: Ablation,
    regions: RegionScoring | None,
) -> SampleScores:
    """One mode's per-sample scores, batch by batch (``score_samples``)."""
    horizon, dt, count = config.data.horizon_steps, config.data.dt_s, len(samples)
    values: dict[str, np.ndarray] = {}
    kept = _SceneKeeper(samples, mode)
    generator = torch.Generator(device=device).manual_seed(seed)  # per mode: score_samples
    iterator = batches(samples, config, batch_size, groups)
    total = -(-count // batch_size)
    for index, batch in tqdm(iterator, total=total, desc=mode, disable=not progress, leave=False):
        batch = batch.to(device)
        truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
        if is_point_forecast(mode):
            named = PointForecast.parse(mode)
            decoded = model.forecast_point(batch, named, horizon, dt, ablate=ablate)
            point = decoded.point.double().cpu().numpy()  # (B, H, 2)
            made_from = _distribution(decoded, regions)
            _store(values, index, count, _point_scores(point, made_from, truth, regions))
            kept.keep(index, point[:, None])
            continue
        best_of = best_of_samples(mode)
        draws = model.forecast_futures(
            batch,
            horizon,
            dt,
            num_samples=best_of or NLL_SAMPLES,
            generator=generator,
            ablate=ablate,
        )
        draws_np = draws.double().cpu().numpy()  # (B, K, H, 2)
        if best_of is not None:
            _store(values, index, count, _best_of_scores(draws_np, truth))
            kept.keep(index, draws_np)
        else:
            _store(values, index, count, {metrics.NLL: metrics.kde_nll(draws_np, truth)})
    return _completed(mode, values | kept.scores(), count)


class _SceneKeeper:
    """A mode's forecasts of every sample, kept while its batches are scored where a
    scene-level metric is registered (each reads a whole moment's forecasts at once), and
    those metrics' scores at the end."""

    def __init__(self, samples: SampleSet, mode: str) -> None:
        self.samples = samples
        self.wanted = bool(metrics.scene_metrics()) and mode != metrics.NLL
        self.forecasts: np.ndarray | None = None  # (S, K, H, 2) once the first batch is kept

    def keep(self, index: np.ndarray, forecasts: np.ndarray) -> None:
        """Keep one batch's (B, K, H, 2) forecasts (relative to each one's present)."""
        if not self.wanted:
            return
        if self.forecasts is None:
            shape = (len(self.samples), *forecasts.shape[1:])
            self.forecasts = np.full(shape, np.nan, dtype=np.float32)  # half the memory
        self.forecasts[index] = forecasts

    def scores(self) -> dict[str, np.ndarray]:
        """Every registered scene-level metric of the kept forecasts, name -> (S,)."""
        if self.forecasts is None:
            return {}
        return scene_scores(self.forecasts, self.samples)


def scene_scores(forecasts: np.ndarray, samples: SampleSet) -> dict[str, np.ndarray]:
    """Every registered scene-level metric of (S, K, H, 2) forecasts relative to each sample's
    present position, name -> (S,); none where none is registered."""
    chosen = metrics.scene_metrics()
    if not chosen:
        return {}
    now = samples.pos_now_scene_m.astype(np.float64)  # (S, 2) in the scene's own frame
    scene = SceneForecasts(
        forecasts.astype(np.float64) + now[:, None, None],
        samples.fut_rel_m.astype(np.float64) + now[:, None],
        moment_ids(samples.scene_index, samples.step),
    )
    return {name: metric.score(scene) for name, metric in chosen.items()}


def _distribution(decoded: PointResult, regions: RegionScoring | None) -> Mixture | None:
    """The distribution a point forecast was made from, where regions are scored."""
    return decoded.distribution().mixture() if regions is not None else None


def _point_scores(
    point: np.ndarray,
    distribution: Mixture | None,
    truth: np.ndarray,
    regions: RegionScoring | None,
) -> dict[str, np.ndarray]:
    """Every registered metric of a batch's (B, H, 2) point forecast, name -> (B,), and its
    displacement error per step, -> (B, H); with ``regions``, every region metric of the
    ``distribution`` it was made from, -> (B, H)."""
    scores = metrics.point_scores(point, truth)
    scores[metrics.DISPLACEMENT] = metrics.displacement_errors(point, truth)
    if regions is not None and distribution is not None:
        scores.update(regions.scores(point, distribution, truth))
    return scores


def _best_of_scores(draws: np.ndarray, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Every registered metric's minimum over a batch's (B, K, H, 2) draws, -> (B,), and each
    step's lowest displacement error, -> (B, H)."""
    scores = metrics.best_of_scores(draws, truth)
    scores[metrics.DISPLACEMENT] = metrics.displacement_errors(draws, truth[:, None]).min(axis=1)
    return scores


def _store(
    values: dict[str, np.ndarray], index: np.ndarray, count: int, batch: dict[str, np.ndarray]
) -> None:
    """Write one batch's (B,) or (B, H) scores per metric into the (S,) or (S, H) arrays at
    ``index``."""
    for name, scores in batch.items():
        values.setdefault(name, np.full((count, *scores.shape[1:]), np.nan))[index] = scores


def _completed(mode: str, values: dict[str, np.ndarray], count: int) -> SampleScores:
    """The scores of one mode: (S, H) ones kept per step, with their per-sample means beside
    the (S,) ones (the displacement error's are the ADE, or not best-of-K's: none); an empty
    sample set's still name the registered metrics."""
    found = values or {name: np.full(count, np.nan) for name in metrics.METRICS}
    per_step = {name: v for name, v in found.items() if v.ndim == 2}
    means = {
        name: v.mean(axis=1) if v.ndim == 2 else v
        for name, v in found.items()
        if name != metrics.DISPLACEMENT
    }
    return SampleScores(mode, means, per_step)


SHARED_DECODE = ("ml", "mean")
"""Point forecasts read from one decode of every latent value (following its means): scored
together, that decode runs once per batch instead of once per forecast, with the same numbers."""


def _score_shared_decode(  # noqa: PLR0913 - score_samples's options, all keyword-only
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    *,
    batch_size: int,
    groups: SampleGroups | None,
    device: torch.device | str,
    ablate: Ablation,
    progress: bool,
    regions: RegionScoring | None,
) -> dict[str, SampleScores]:
    """The ``SHARED_DECODE`` forecasts' per-sample scores, in one pass over the batches (both
    made from the one distribution of all Z latent values)."""
    horizon, dt, count = config.data.horizon_steps, config.data.dt_s, len(samples)
    scores: dict[str, dict[str, np.ndarray]] = {mode: {} for mode in SHARED_DECODE}
    kept = {mode: _SceneKeeper(samples, mode) for mode in SHARED_DECODE}
    iterator = batches(samples, config, batch_size, groups)
    total = -(-count // batch_size)
    for index, batch in tqdm(
        iterator, total=total, desc="+".join(SHARED_DECODE), disable=not progress, leave=False
    ):
        batch = batch.to(device)
        truth = batch.fut_rel_m.double().cpu().numpy()  # (B, H, 2)
        decoded: Decoded = model.forecast_point(
            batch, PointForecast("ml"), horizon, dt, ablate=ablate
        )
        predictions = {  # ml decodes all Z, whose weighted mean is the mean forecast
            "ml": decoded.point,
            "mean": mixture_mean_positions(decoded.encoding, decoded.velocity, dt),
        }
        made_from = _distribution(decoded, regions)  # all Z: the same for both
        for mode, values in scores.items():
            pred = predictions[mode].double().cpu().numpy()  # (B, H, 2)
            _store(values, index, count, _point_scores(pred, made_from, truth, regions))
            kept[mode].keep(index, pred[:, None])
    return {mode: _completed(mode, v | kept[mode].scores(), count) for mode, v in scores.items()}


def evaluate_model(  # noqa: PLR0913 - score_samples's options, all keyword-only
    model: Forecaster,
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


def forecast_scores(mode: str, positions: np.ndarray, samples: SampleSet) -> SampleScores:
    """Per-sample scores of forecasts made anywhere, as ``score_samples`` scores a model's:
    (S, H, 2) point forecasts, or the best of (S, K, H, 2) samples (each relative to its
    sample's present position), against the ``samples``' truths."""
    truth = samples.fut_rel_m.astype(np.float64)
    if positions.ndim == 3:
        scores = _point_scores(positions, None, truth, None)
        return _completed(mode, scores | scene_scores(positions[:, None], samples), len(truth))
    scores = _best_of_scores(positions, truth)
    return _completed(mode, scores | scene_scores(positions, samples), len(truth))


def constant_velocity_scores(samples: SampleSet, horizon_steps: int) -> SampleScores:
    """Per-sample ADE/FDE (metres), every registered metric and the displacement error of
    every step of constant velocity, the one baseline every table shows."""
    pred = constant_velocity(samples.hist_rel_m.astype(np.float64), horizon_steps)
    return forecast_scores("ml", pred, samples)
