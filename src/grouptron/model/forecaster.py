"""The forecaster interface: what any model defines to be trained, to forecast and to be saved
and loaded by every command (train, evaluate, report, predict, plot, calibrate, the live node).

A forecaster is a ``torch.nn.Module`` subclass of :class:`Forecaster` built from an
:class:`ExperimentConfig` (its own settings in ``config.model_settings``, JSON). It defines

- ``training_loss(batch, step)``: a scalar to minimise on a :class:`Batch`;
- ``sample(batch, horizon, dt_s, num_samples, generator)``: (B, K, H, 2) futures relative to
  each person's position now, metres;
- optionally ``point(batch, forecast, horizon, dt_s)``: its own point forecast (the default is
  the mean of :data:`POINT_SAMPLES` seeded samples) and ``point_forecasts``, the kinds it makes.

A checkpoint stores the class's name (``config.model_name``: a shipped model's name,
``package.module:Class`` or a ``grouptron.models`` entry point), its settings and its weights;
loading imports the class from installed code or the current folder, never code from the file.
The two CVAEs implement the interface (``model.cvae``); docs/models.md adds a model.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, TypeVar

import numpy as np
import torch
from torch import nn

from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch
from grouptron.model.gaussians import covariance_matrices
from grouptron.model.mixture import Mixture
from grouptron.point_forecast import PointForecast
from grouptron.presets import MODEL_NAMES

if TYPE_CHECKING:
    from grouptron.config import ExperimentConfig

SettingsT = TypeVar("SettingsT")
"""A model's own settings dataclass (:func:`model_settings`)."""

ENTRY_POINT_GROUP = "grouptron.models"
"""Packages name their forecasters under this entry-point group (``name = "pkg.mod:Class"``)."""
POINT_SAMPLES = 20
"""Samples whose per-step mean is the point forecast of a model without one of its own."""
POINT_SEED = 0
KDE_FLOOR_M = 0.01
"""Least standard deviation of a sampled forecast's kernels, metres: a model whose samples
coincide (a deterministic one) still has a distribution that regions can be drawn from."""


class LossLike(Protocol):
    """A training step's loss: ``loss`` () is minimised, ``as_floats`` is logged per epoch."""

    @property
    def loss(self) -> torch.Tensor:
        """() the value minimised."""
        ...

    def as_floats(self) -> dict[str, float]:
        """The loss and its terms as floats, by name."""
        ...


@dataclass(frozen=True)
class Loss:
    """A loss and the terms it is made of (each a () tensor), logged as ``train_<name>``."""

    loss: torch.Tensor
    terms: Mapping[str, torch.Tensor]

    def as_floats(self) -> dict[str, float]:
        """The loss and its terms as detached Python floats, by name."""
        found = {"loss": float(self.loss.detach())}
        found.update({k: float(v.detach()) for k, v in self.terms.items()})
        return found


BatchMean = Callable[[torch.Tensor], torch.Tensor]
"""(B, ...) per-sample values -> (...) their mean over the (global) batch."""


@dataclass(frozen=True)
class TrainingStep:
    """What one optimiser step hands the model besides its batch.

    Attributes:
        config: the run's settings (``data.dt_s``, ``data.horizon_steps``, ``model_settings``).
        iteration: optimiser steps completed before this one (schedules read it).
        noise: what :meth:`Forecaster.training_noise` drew, this process's rows, on the
            model's device; None when it draws none (then draw from torch's global RNG, which
            the run seeds and saves).
        batch_mean: the mean over the whole batch, also when it is split across processes:
            a loss averaged with it is the same whichever way the batch is split.
    """

    config: ExperimentConfig
    iteration: int
    noise: Any
    batch_mean: BatchMean


class RowNoise(Protocol):
    """A step's random draws for the global batch (:meth:`Forecaster.training_noise`)."""

    def rows(self, index: np.ndarray) -> RowNoise:
        """The draws of the samples ``index`` (one process's rows of the batch)."""
        ...

    def to(self, device: torch.device | str) -> RowNoise:
        """A copy on ``device``."""
        ...


@dataclass(frozen=True)
class Gaussians:
    """Position Gaussians of M components per sample, relative to ``t``: a forecast's
    distribution as the model makes it (:meth:`mixture` turns it into a :class:`Mixture`).

    Attributes:
        log_weights: (B, M) log weights, normalised over the M components.
        means: (B, M, H, 2) position means relative to ``t``, metres.
        covariances: (B, M, H, 3) their covariance entries (var_x, cov_xy, var_y), m^2.
    """

    log_weights: torch.Tensor
    means: torch.Tensor
    covariances: torch.Tensor

    def mixture(self) -> Mixture:
        """Float64 NumPy, relative to ``t``, covariances as (B, M, H, 2, 2) matrices."""
        return Mixture(
            log_weights=self.log_weights.double().cpu().numpy(),
            means=self.means.double().cpu().numpy(),
            covariances=covariance_matrices(self.covariances).double().cpu().numpy(),
        )


class PointResult(Protocol):
    """A batch's point forecast and the distribution it comes with."""

    @property
    def point(self) -> torch.Tensor:
        """(B, H, 2) positions relative to ``t``, metres."""
        ...

    def distribution(self) -> Gaussians:
        """The distribution the point forecast was made from (regions are drawn from it)."""
        ...

    def mixture(self) -> Gaussians | None:
        """The model's whole distribution, where asked for and it differs (else None)."""
        ...


def kernel_density(samples: torch.Tensor) -> Gaussians:
    """The Gaussian kernel density of (B, K, H, 2) samples per step: equal weights, a kernel
    at each sample whose covariance is Scott's rule on the K samples (as the KDE NLL metric's,
    ``grouptron.evaluation.metrics.kde_nll``) plus :data:`KDE_FLOOR_M` squared."""
    B, K = samples.shape[:2]
    values = samples.double()
    centred = values - values.mean(dim=1, keepdim=True)  # (B, K, H, 2)
    denominator = max(K - 1, 1)
    var_x = (centred[..., 0] ** 2).sum(dim=1) / denominator  # (B, H)
    cov_xy = (centred[..., 0] * centred[..., 1]).sum(dim=1) / denominator
    var_y = (centred[..., 1] ** 2).sum(dim=1) / denominator
    scott = K ** (-1.0 / 3.0)  # Scott's factor squared, K^(-1/(d+4)) with d = 2
    floor = KDE_FLOOR_M**2
    entries = torch.stack([scott * var_x + floor, scott * cov_xy, scott * var_y + floor], -1)
    return Gaussians(
        log_weights=torch.full((B, K), -float(np.log(K)), dtype=values.dtype),
        means=values,
        covariances=entries[:, None].expand(B, K, *entries.shape[1:]),  # (B, K, H, 3)
    )


@dataclass(frozen=True)
class SampledPoint:
    """A point forecast with the samples its distribution is the kernel density of.

    Attributes:
        point: (B, H, 2) positions relative to ``t``, metres.
        samples: (B, K, H, 2) sampled futures.
    """

    point: torch.Tensor
    samples: torch.Tensor

    def distribution(self) -> Gaussians:
        """The samples' kernel density (:func:`kernel_density`)."""
        return kernel_density(self.samples)

    def mixture(self) -> Gaussians | None:
        """The same distribution: a sampled model has no other."""
        return self.distribution()


@dataclass(frozen=True)
class GaussianPoint:
    """A point forecast with the Gaussians it was made from (a model's own distribution).

    Attributes:
        point: (B, H, 2) positions relative to ``t``, metres.
        gaussians: its distribution, M components.
    """

    point: torch.Tensor
    gaussians: Gaussians

    def distribution(self) -> Gaussians:
        """``gaussians``."""
        return self.gaussians

    def mixture(self) -> Gaussians | None:
        """``gaussians``: the model has no other distribution."""
        return self.gaussians


class Forecaster(nn.Module):
    """The interface every model implements (the module docstring says what each part is).

    Subclasses outside the package define ``__init__(self, config)``, :meth:`training_loss`
    and :meth:`sample`, and may define :meth:`point` with ``point_forecasts``.

    Attributes:
        reads_groups: whether its batches carry the samples' groups (``Batch.groups``).
        point_forecasts: the kinds of point forecast it makes (``ml``, ``mean``), its default
            first; without a :meth:`point` of its own only ``mean`` (of its samples).
    """

    reads_groups: ClassVar[bool] = False
    point_forecasts: ClassVar[tuple[str, ...]] = ("mean",)

    @property
    def latent_values(self) -> int:
        """Discrete components its point forecasts choose among (1 for a model without)."""
        return 1

    @property
    def ablations(self) -> tuple[str, ...]:
        """The inputs an evaluation may take away from it (``evaluate --ablate``): none."""
        return ()

    def training_noise(self, rows: int, config: ExperimentConfig) -> RowNoise | None:
        """Random draws of a step for the whole global batch of ``rows`` samples, split by
        rows between processes (None: the model draws its own in the step)."""
        return None

    def training_loss(self, batch: Batch, step: TrainingStep) -> LossLike:
        """The scalar minimised on ``batch`` (:class:`Loss` with the terms to log)."""
        raise GrouptronError(f"{type(self).__name__} defines no training_loss(batch, step)")

    def sample(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        num_samples: int,
        generator: torch.Generator | None = None,
    ) -> torch.Tensor:
        """(B, K, H, 2) ``num_samples`` futures per sample relative to ``t``, metres, drawn
        with ``generator`` (None: the global RNG)."""
        raise GrouptronError(f"{type(self).__name__} defines no sample(batch, horizon, ...)")

    def point(
        self, batch: Batch, forecast: PointForecast, horizon: int, dt_s: float
    ) -> PointResult:
        """The point forecast ``forecast`` (a kind in ``point_forecasts``): by default the
        per-step mean of :data:`POINT_SAMPLES` samples drawn with seed :data:`POINT_SEED`,
        with their kernel density as its distribution."""
        generator = torch.Generator(device=batch.hist_st.device).manual_seed(POINT_SEED)
        drawn = self.sample(batch, horizon, dt_s, POINT_SAMPLES, generator)  # (B, K, H, 2)
        return SampledPoint(point=drawn.mean(dim=1), samples=drawn)

    # What the engine, the evaluation and training call; the CVAE overrides the first two to
    # add ablations and the distribution of all its latent values.
    def forecast_point(
        self,
        batch: Batch,
        forecast: PointForecast,
        horizon: int,
        dt_s: float,
        *,
        every: bool = False,
        ablate: tuple[str, ...] = (),
    ) -> PointResult:
        """:meth:`point` after checking that the model makes ``forecast`` and has ``ablate``'s
        inputs (``every``: its whole distribution too; :meth:`PointResult.mixture`)."""
        self.check_ablation(ablate)
        self.check_point_forecast(forecast)
        made = self.point(batch, forecast, horizon, dt_s)
        _check_shape(self, "point", made.point, (len(batch), horizon, 2))
        return made

    def forecast_futures(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        *,
        num_samples: int,
        generator: torch.Generator | None = None,
        ablate: tuple[str, ...] = (),
    ) -> torch.Tensor:
        """:meth:`sample` after checking ``ablate``."""
        self.check_ablation(ablate)
        drawn = self.sample(batch, horizon, dt_s, num_samples, generator)
        _check_shape(self, "sample", drawn, (len(batch), num_samples, horizon, 2))
        return drawn

    def check_point_forecast(self, forecast: PointForecast) -> None:
        """Refuse, in one line, a kind of point forecast this model does not make."""
        if forecast.kind not in self.point_forecasts:
            made = ", ".join(self.point_forecasts)
            raise GrouptronError(
                f"{type(self).__name__} makes no {forecast.kind} forecast (it makes {made}); "
                f"use --forecast {self.point_forecasts[0]}, or best-of-K from its samples"
            )

    def check_ablation(self, ablate: tuple[str, ...]) -> None:
        """Refuse, in one line, an ablation of inputs this model does not have."""
        missing = sorted(set(ablate) - set(self.ablations))
        if missing:
            raise GrouptronError(
                f"{type(self).__name__} cannot be evaluated without {', '.join(missing)}: it "
                f"takes away {', '.join(self.ablations) or 'no inputs'}"
            )


def _check_shape(
    model: Forecaster, method: str, made: torch.Tensor, expected: tuple[int, ...]
) -> None:
    """Refuse in one line a forecast whose shape is not the interface's."""
    if tuple(made.shape) != expected:
        raise GrouptronError(
            f"{type(model).__name__}.{method} returned shape {tuple(made.shape)}, not "
            f"{expected} (samples, [futures,] steps, x/y)"
        )


def model_settings(kind: type[SettingsT], config: ExperimentConfig) -> SettingsT:
    """``config.model_settings`` read as the frozen dataclass ``kind`` (a model's own
    settings); a name it does not have is refused in one line naming the model."""
    try:
        return kind(**config.model_settings)
    except TypeError as error:
        raise GrouptronError(f"{config.model_name}: {error}") from None


def latent_values_of(config: ExperimentConfig) -> int:
    """Z of the model ``config`` describes: a CVAE's latent values, 1 for a model of the
    interface (whose ``ml-topK`` forecasts are its ``ml``)."""
    return 1 if is_outside_name(config.model_name) else config.model.latent_values


def is_outside_name(name: str) -> bool:
    """Whether a model name is not one of the shipped models' (a class or an entry point)."""
    return name not in MODEL_NAMES


def outside_forecaster(name: str) -> type[Forecaster]:
    """The class ``name`` names: ``package.module:Class`` (an installed module, or one in the
    current folder) or an entry point of :data:`ENTRY_POINT_GROUP`.

    Raises:
        GrouptronError: for a name that names nothing, or something not a Forecaster.
    """
    if ":" in name:
        module_name, _, attribute = name.partition(":")
        found: Any = _imported(module_name, name)
        for part in attribute.split("."):
            found = getattr(found, part, None)
    else:
        points = {point.name: point for point in entry_points(group=ENTRY_POINT_GROUP)}
        if name not in points:
            raise GrouptronError(
                f"unknown model {name!r}; choose from {', '.join(MODEL_NAMES + tuple(points))}, "
                "or name a class as package.module:Class"
            )
        found = _loaded(points[name].load, name)
    if not (isinstance(found, type) and issubclass(found, Forecaster)):
        raise GrouptronError(
            f"model {name!r} is not a grouptron.model.forecaster.Forecaster subclass"
        )
    return found


def _imported(module_name: str, name: str) -> Any:
    """The module, imported from installed code or else from the current folder (which joins
    the import path for that import only)."""
    here, root = os.getcwd(), module_name.split(".")[0]
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name != root:  # the model's module was found; something it imports was not
            raise GrouptronError(f"model {name!r}: importing it failed ({exc})") from None
    except Exception as exc:
        raise _failed(name, exc) from None
    if not (Path(here) / f"{root}.py").is_file() and not (Path(here) / root).is_dir():
        raise GrouptronError(
            f"model {name!r}: cannot import it: no module {root!r} is installed or in the "
            "current folder"
        )
    sys.path.insert(0, here)  # as ``python -m`` would: a model written beside the data
    try:
        return _loaded(lambda: importlib.import_module(module_name), name)
    finally:
        sys.path.remove(here)


def _failed(name: str, exc: Exception) -> GrouptronError:
    return GrouptronError(f"model {name!r}: importing it failed ({type(exc).__name__}: {exc})")


def _loaded(load: Callable[[], Any], name: str) -> Any:
    """What ``load`` returns; its import's failure in one line."""
    try:
        return load()
    except Exception as exc:
        raise GrouptronError(
            f"model {name!r}: importing it failed ({type(exc).__name__}: {exc})"
        ) from None
