"""The one forecasting engine: samples (people at their forecast steps) in, point forecasts and
their distributions out. ``Predictor`` (and through it live sessions), whole-file forecasts
and calibration all forecast here; evaluation scores the same ``model.predict.decode``."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import torch
from tqdm import tqdm

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import Batch, batches
from grouptron.model.forecaster import Forecaster
from grouptron.model.mixture import Mixture
from grouptron.point_forecast import PointForecast


@dataclass(frozen=True, eq=False)
class Forecasts:
    """Every sample's forecast relative to its position now (float64 NumPy, metres).

    Attributes:
        point: (S, H, 2) the point forecast.
        distribution: the M latent values' Gaussians it was made from (None unless asked).
        mixture: all Z latent values' Gaussians (None unless asked).
        samples: (S, K, H, 2) sampled futures (None unless asked).
    """

    point: np.ndarray
    distribution: Mixture | None
    mixture: Mixture | None
    samples: np.ndarray | None


@dataclass(frozen=True)
class EngineOptions:
    """What to make besides the point forecast, and how.

    Attributes:
        distribution: keep the Gaussians the point forecast was made from (regions need them;
            about 1 KB per forecast and latent value).
        mixture: keep those of all Z latent values too (decodes all of them).
        num_samples: sampled futures per sample (0: none), drawn with ``seed``.
        batch_size: samples per network call.
        device: where the network runs.
        progress: a progress bar over the batches.
    """

    distribution: bool = True
    mixture: bool = False
    num_samples: int = 0
    seed: int = 0
    batch_size: int = 512
    device: torch.device | str = "cpu"
    progress: bool = False


@torch.inference_mode()
def forecast_samples(
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    forecast: PointForecast,
    groups: SampleGroups | None,
    options: EngineOptions = EngineOptions(),
) -> Forecasts:
    """The point forecast ``forecast`` of every sample (and what ``options`` asks for), with
    Grouptron's ``groups`` of every sample (None for a model that reads none)."""
    size = max(1, options.batch_size)
    loader = batches(samples, config, size, groups)
    batched = tqdm(loader, total=-(-len(samples) // size), disable=not options.progress)
    return _decode_batches(model.eval(), config, batched, len(samples), forecast, options)


def _decode_batches(
    model: Forecaster,
    config: ExperimentConfig,
    batched: Iterable[tuple[np.ndarray, Batch]],
    count: int,
    forecast: PointForecast,
    options: EngineOptions,
) -> Forecasts:
    H, dt, K = config.data.horizon_steps, config.data.dt_s, options.num_samples
    generator = torch.Generator(device=options.device).manual_seed(options.seed)
    point = np.empty((count, H, 2))
    drawn = np.empty((count, K, H, 2))
    own: list[Mixture] = []
    every: list[Mixture] = []
    for index, batch in batched:  # consecutive, in order
        batch = batch.to(options.device)
        decoded = model.forecast_point(batch, forecast, H, dt, every=options.mixture)
        point[index] = decoded.point.double().cpu().numpy()
        if options.distribution:
            own.append(decoded.distribution().mixture())
        whole = decoded.mixture() if options.mixture else None
        if whole is not None:
            every.append(whole.mixture())
        if K:
            pred = model.forecast_futures(batch, H, dt, num_samples=K, generator=generator)
            drawn[index] = pred.double().cpu().numpy()
    Z = model.latent_values
    M = forecast.latent_values(Z)
    return Forecasts(
        point=point,
        distribution=_joined(own, M, H) if options.distribution else None,
        mixture=_joined(every, Z, H) if options.mixture else None,
        samples=drawn if K else None,
    )


def _joined(parts: list[Mixture], components: int, horizon: int) -> Mixture:
    """The batches' mixtures as one (the batches are consecutive, in sample order)."""
    return Mixture.concatenate(parts) if parts else Mixture.empty(components, horizon)
