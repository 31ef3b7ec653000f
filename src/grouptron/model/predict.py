"""Predictions of a trained CVAE: most likely (mixture mode or argmax latent), the mixture's
mean, and samples."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np
import torch

from grouptron import constants
from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch
from grouptron.model.cvae import Encoding, TrajectronCVAE, VelocityGaussians
from grouptron.model.gaussians import (
    covariance_matrices,
    position_covariances,
    positions_from_velocities,
)
from grouptron.model.mixture_mode import mixture_mode

ABLATIONS = constants.ABLATIONS
"""Inputs an evaluation can take away to see what a model uses: ``edges`` zeroes the
neighbour input of the edge encoder, ``scene`` zeroes Grouptron's scene encoding E_scene."""
Ablation = tuple[str, ...]
PointForecast = Callable[[TrajectronCVAE, Batch, int, float, Ablation], torch.Tensor]
"""(model, batch, horizon steps, dt in s, ablation) -> (B, H, 2) positions relative to t."""


def encode_prior(model: TrajectronCVAE, batch: Batch, ablate: Ablation = ()) -> Encoding:
    """Condition and p(z|x) logits (no posterior, no clipping), with ``ablate``'s inputs
    zeroed."""
    unknown = sorted(set(ablate) - set(ABLATIONS))
    if unknown:
        raise GrouptronError(f"unknown ablation {', '.join(unknown)}; choose from {ABLATIONS}")
    if "edges" in ablate:
        count = None if batch.nbr_count is None else torch.zeros_like(batch.nbr_count)
        batch = dataclasses.replace(
            batch, nbr_sum_st=torch.zeros_like(batch.nbr_sum_st), nbr_count=count
        )
    x = model.encode_condition(batch)  # (B, Dx)
    if "scene" in ablate:
        width = model.condition_dim - model.base_condition_dim  # E_scene's, last in x
        if width == 0:
            raise GrouptronError("--ablate scene needs a model with a scene encoding (Grouptron)")
        x = torch.cat([x[:, :-width], torch.zeros_like(x[:, -width:])], dim=-1)
    return model.encode(batch, x, with_future=False, logit_clip=None)


def predict_most_likely(
    model: TrajectronCVAE, batch: Batch, horizon: int, dt_s: float, ablate: Ablation = ()
) -> torch.Tensor:
    """The reference's most-likely prediction, (B, H, 2) positions relative to ``t``.

    Every latent value is decoded feeding back its mean; at each step the velocity is the mode
    of the Z-component mixture weighted by p(z|x); velocities are integrated to positions.
    """
    encoding, velocity = decode_every_latent(model, batch, horizon, ablate)
    return most_likely_positions(encoding, velocity, horizon, dt_s)


def decode_every_latent(
    model: TrajectronCVAE, batch: Batch, horizon: int, ablate: Ablation = ()
) -> tuple[Encoding, VelocityGaussians]:
    """p(z|x) and the velocity Gaussians of all Z latent values, each following its means."""
    encoding = encode_prior(model, batch, ablate)
    return encoding, model.decode(encoding.x, batch.state_now_st, None, horizon, feedback="mean")


MODE_STARTS = 4
"""Climbs per mixture for the benchmark's most likely forecast (all Z latent values)."""
TOP_MODE_STARTS = 1
"""Climbs per mixture for the mode of the few most probable latent values (``ml-top10``,
``Predictor(latent_values=k)``), from the component mean where the mixture is densest. Those
mixtures are unimodal nearly always, and each further start costs as much as the first (the
climb was half of a live update): with the default model one start gives the four starts'
forecasts exactly on every validation file of the five splits and the out-of-domain
development set; with plain Trajectron++ 6 of 2,800 univ validation forecasts move, by at
most 28 mm (benchmarks/RESULTS.md, "Where the default forecast's time goes")."""


def most_likely_positions(
    encoding: Encoding,
    velocity: VelocityGaussians,
    horizon: int,
    dt_s: float,
    num_starts: int = MODE_STARTS,
) -> torch.Tensor:
    """(B, H, 2): per step, the mode of the p(z|x)-weighted velocity mixture of the M decoded
    latent values, integrated (one value: its means); ``num_starts`` climbs per mixture."""
    B, M = encoding.p_logits.shape
    if M == 1:
        return positions_from_velocities(velocity.mean[:, 0], dt_s)
    log_weights = encoding.p_logits[:, None, :].expand(B, horizon, M)  # (B, H, M)
    mode = mixture_mode(
        log_weights.reshape(B * horizon, M),
        velocity.mean.transpose(1, 2).reshape(B * horizon, M, 2),  # (B*H, M, 2)
        velocity.cov.transpose(1, 2).reshape(B * horizon, M, 3),
        num_starts,
    ).reshape(B, horizon, 2)
    return positions_from_velocities(mode, dt_s).float()


def predict_mixture_mean(
    model: TrajectronCVAE, batch: Batch, horizon: int, dt_s: float, ablate: Ablation = ()
) -> torch.Tensor:
    """(B, H, 2): the p(z|x)-weighted mean of every latent value's trajectory (each decoded
    following its means), relative to ``t``.

    The mean, unlike the per-step mixture mode, never jumps between latent values from one step
    to the next; it is the mean of the mixture these decoded trajectories make (under that
    mixture, the forecast with the least expected squared error).
    """
    encoding, velocity = decode_every_latent(model, batch, horizon, ablate)
    return mixture_mean_positions(encoding, velocity, dt_s)


def mixture_mean_positions(
    encoding: Encoding, velocity: VelocityGaussians, dt_s: float
) -> torch.Tensor:
    """(B, H, 2): the ``encoding.p_logits``-weighted mean of the (B, M, H, 2) decoded velocity
    means, integrated (integration is linear, so this is the mean of the positions)."""
    weights = torch.softmax(encoding.p_logits, dim=-1)  # (B, M)
    mean_velocity = (weights[:, :, None, None] * velocity.mean).sum(dim=1)  # (B, H, 2)
    return positions_from_velocities(mean_velocity, dt_s).float()


def predict_most_likely_of_top(
    model: TrajectronCVAE,
    batch: Batch,
    horizon: int,
    dt_s: float,
    ablate: Ablation = (),
    *,
    latent_values: int,
) -> torch.Tensor:
    """(B, H, 2): the most likely prediction of the mixture of only the ``latent_values`` most
    probable latent values (each decoded following its means; the mode per step, integrated).

    All Z values is :func:`predict_most_likely`, one is :func:`predict_argmax_latent`; a few
    come close to all at a fraction of the cost (benchmarks/most_likely.py).
    """
    encoding = encode_prior(model, batch, ablate)
    top_logits, top = encoding.p_logits.topk(latent_values, dim=-1)  # (B, M)
    velocity = model.decode(encoding.x, batch.state_now_st, top, horizon, feedback="mean")
    trimmed = Encoding(x=encoding.x, p_logits=top_logits, q_logits=None)
    starts = mode_starts(latent_values, model.config.latent_modes)
    return most_likely_positions(trimmed, velocity, horizon, dt_s, starts)


def forecast_name(mode: str, latent_values: int | None, latent_modes: int) -> str:
    """The one name of a point forecast for a model of ``latent_modes`` latent values: ``ml``
    of all of them is ``ml`` (so is ``ml-top10`` of a model with at most 10), ``ml`` of the K
    most probable ``ml-topK``, of one ``ml-argmax``."""
    kind, M = decoded_latent_values(mode, latent_values, latent_modes)
    if kind != "ml" or latent_modes == M:
        return kind
    if M == 1:  # the mode of one Gaussian is its mean
        return "ml-argmax"
    return f"ml-top{M}"


def mode_starts(decoded: int, latent_modes: int) -> int:
    """Climbs per mixture for the mode of ``decoded`` of the ``latent_modes`` latent values:
    the benchmark's :data:`MODE_STARTS` for all of them, :data:`TOP_MODE_STARTS` for fewer."""
    return TOP_MODE_STARTS if decoded < latent_modes else MODE_STARTS


def decoded_latent_values(
    mode: str, latent_values: int | None, latent_modes: int
) -> tuple[str, int]:
    """``(kind, M)``: the point forecast ``mode`` as ``ml``, ``ml-argmax`` or ``mean``, and how
    many of the most probable latent values it reads (``ml-top10``: ``ml`` of 10, or of all
    when the model has fewer; ``ml-topK`` likewise; ``ml`` of ``latent_values`` when given)."""
    top = constants.top_forecast_size(mode)
    if top is not None:  # ml-top10, or ml-topK as forecast_name writes it
        return "ml", min(top, latent_modes)
    if mode == "ml-argmax":
        return mode, 1
    if mode == "mean":
        return mode, latent_modes
    return "ml", latent_values or latent_modes


def top_latent_values(
    encoding: Encoding, velocity: VelocityGaussians, latent_values: int
) -> tuple[Encoding, VelocityGaussians]:
    """The ``latent_values`` most probable of all Z decoded latent values: (B, M) logits and
    (B, M, ...) Gaussians, most probable first."""
    top_logits, top = encoding.p_logits.topk(latent_values, dim=-1)  # (B, M)
    rows = torch.arange(len(top), device=top.device)[:, None]
    return Encoding(x=encoding.x, p_logits=top_logits, q_logits=None), VelocityGaussians(
        mean=velocity.mean[rows, top],
        log_sigma=velocity.log_sigma[rows, top],
        corr=velocity.corr[rows, top],
        fed_back=velocity.fed_back[rows, top],
    )


def most_likely_of_decoded_top(
    encoding: Encoding, velocity: VelocityGaussians, latent_values: int, dt_s: float
) -> torch.Tensor:
    """(B, H, 2): the most likely forecast of the ``latent_values`` most probable of all Z
    decoded latent values, as :func:`predict_most_likely_of_top` makes it (all Z: ``ml``)."""
    Z, horizon = velocity.mean.shape[1], velocity.mean.shape[2]
    top = top_latent_values(encoding, velocity, latent_values)
    return most_likely_positions(*top, horizon, dt_s, mode_starts(latent_values, Z))


@dataclasses.dataclass(frozen=True)
class ForecastGaussians:
    """The position Gaussians of the M latent values a point forecast was made from (10 for
    ``ml-top10``, 1 for ``ml-argmax``, all Z for ``ml`` and ``mean``): the forecast's own
    distribution, from which prediction regions are drawn (``model/regions.py``).

    Attributes:
        log_weights: (B, M) log p(z|x) renormalised over the M values.
        means: (B, M, H, 2) position means relative to ``t``, metres.
        covariances: (B, M, H, 3) their covariance entries (var_x, cov_xy, var_y), m^2.
    """

    log_weights: torch.Tensor
    means: torch.Tensor
    covariances: torch.Tensor

    def as_arrays(self, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Float64 NumPy: (B, M) log weights, (B, M, H, 2) means moved to the (B, 2)
        ``origin`` and (B, M, H, 2, 2) covariance matrices."""
        means = self.means.double().cpu().numpy() + origin[:, None, None, :]
        covariances = covariance_matrices(self.covariances).double().cpu().numpy()
        return self.log_weights.double().cpu().numpy(), means, covariances


def point_forecast_and_gaussians(
    model: TrajectronCVAE,
    batch: Batch,
    horizon: int,
    dt_s: float,
    mode: str,
    latent_values: int | None = None,
) -> tuple[torch.Tensor, ForecastGaussians]:
    """(B, H, 2) point forecast ``mode`` (``ml`` of the ``latent_values`` most probable latent
    values when given) and the Gaussians it was made from, decoding only those."""
    Z = model.config.latent_modes
    kind, M = decoded_latent_values(mode, latent_values, Z)
    encoding = encode_prior(model, batch)
    z_index = None  # all of them
    if M < Z:
        logits, z_index = encoding.p_logits.topk(M, dim=-1)  # (B, M)
        encoding = Encoding(x=encoding.x, p_logits=logits, q_logits=None)
    velocity = model.decode(encoding.x, batch.state_now_st, z_index, horizon, feedback="mean")
    if kind == "mean":
        point = mixture_mean_positions(encoding, velocity, dt_s)
    else:
        point = most_likely_positions(encoding, velocity, horizon, dt_s, mode_starts(M, Z))
    return point, forecast_gaussians(encoding, velocity, dt_s)


def point_forecast_and_mixture(
    model: TrajectronCVAE,
    batch: Batch,
    horizon: int,
    dt_s: float,
    mode: str,
    latent_values: int | None = None,
) -> tuple[torch.Tensor, ForecastGaussians, ForecastGaussians]:
    """:func:`point_forecast_and_gaussians` and the Gaussians of all Z latent values, from one
    decoding of all of them (the forecast is the same)."""
    Z = model.config.latent_modes
    kind, M = decoded_latent_values(mode, latent_values, Z)
    encoding, velocity = decode_every_latent(model, batch, horizon)
    every = forecast_gaussians(encoding, velocity, dt_s)
    if kind == "mean":
        return mixture_mean_positions(encoding, velocity, dt_s), every, every
    top = top_latent_values(encoding, velocity, M)
    point = most_likely_positions(*top, horizon, dt_s, mode_starts(M, Z))
    return point, forecast_gaussians(*top, dt_s), every


def forecast_gaussians(
    encoding: Encoding, velocity: VelocityGaussians, dt_s: float
) -> ForecastGaussians:
    """The decoded latent values' velocity Gaussians as position Gaussians."""
    return ForecastGaussians(
        log_weights=torch.log_softmax(encoding.p_logits, dim=-1),
        means=positions_from_velocities(velocity.mean, dt_s),
        covariances=position_covariances(velocity.cov, dt_s),
    )


def predict_argmax_latent(
    model: TrajectronCVAE, batch: Batch, horizon: int, dt_s: float, ablate: Ablation = ()
) -> torch.Tensor:
    """(B, H, 2): decode only the most probable latent value and follow its means."""
    encoding = encode_prior(model, batch, ablate)
    z_index = encoding.p_logits.argmax(dim=-1, keepdim=True)  # (B, 1)
    velocity = model.decode(encoding.x, batch.state_now_st, z_index, horizon, feedback="mean")
    return positions_from_velocities(velocity.mean[:, 0], dt_s)


def predict_samples(
    model: TrajectronCVAE,
    batch: Batch,
    horizon: int,
    dt_s: float,
    *,
    num_samples: int,
    generator: torch.Generator | None = None,
    ablate: Ablation = (),
) -> torch.Tensor:
    """(B, K, H, 2) futures with z ~ p(z|x) and a velocity sample drawn (and fed back) per step."""
    encoding = encode_prior(model, batch, ablate)
    probs = torch.softmax(encoding.p_logits, dim=-1)
    z_index = torch.multinomial(probs, num_samples, replacement=True, generator=generator)
    velocity = model.decode(
        encoding.x, batch.state_now_st, z_index, horizon, feedback="sample", generator=generator
    )
    return positions_from_velocities(velocity.fed_back, dt_s)


TOP_LATENT_VALUES = 10
"""The latent values of the ``ml-top10`` forecast."""


def _most_likely_of_named_top(
    name: str,
    model: TrajectronCVAE,
    batch: Batch,
    horizon: int,
    dt_s: float,
    ablate: Ablation = (),
) -> torch.Tensor:
    """(B, H, 2): :func:`predict_most_likely_of_top` of the K latent values ``ml-topK`` names
    (all of them in a model with fewer)."""
    _, top = decoded_latent_values(name, None, model.config.latent_modes)
    return predict_most_likely_of_top(model, batch, horizon, dt_s, ablate, latent_values=top)


def predict_most_likely_of_top10(
    model: TrajectronCVAE, batch: Batch, horizon: int, dt_s: float, ablate: Ablation = ()
) -> torch.Tensor:
    """(B, H, 2): :func:`predict_most_likely_of_top` of the 10 most probable latent values
    (all of them in a model with fewer)."""
    return _most_likely_of_named_top("ml-top10", model, batch, horizon, dt_s, ablate)


POINT_FORECASTS: dict[str, PointForecast] = {
    "ml": predict_most_likely,
    "ml-argmax": predict_argmax_latent,
    "mean": predict_mixture_mean,
    "ml-top10": predict_most_likely_of_top10,
}
"""The named single-trajectory forecasts: the mixture mode per step (the benchmark's most
likely), the most probable latent value's means, the p(z|x)-weighted mean trajectory, and the
mixture mode of only the 10 most probable latent values (as close to ``ml`` on ETH/UCY
validation data, cheaper, and steadier on recordings from elsewhere: benchmarks/RESULTS.md).
:func:`point_forecast` adds ``ml-topK`` for any K."""
assert tuple(POINT_FORECASTS) == constants.POINT_FORECAST_NAMES  # the command line's names


def point_forecast(name: str) -> PointForecast:
    """The forecast named ``name``: one of :data:`POINT_FORECASTS`, or ``ml-topK`` (the most
    likely forecast of the K most probable latent values, all of them in a model with fewer)."""
    if name in POINT_FORECASTS:
        return POINT_FORECASTS[name]
    if constants.top_forecast_size(name) is None:
        raise GrouptronError(
            f"unknown point forecast {name!r}; choose from {', '.join(POINT_FORECASTS)} or "
            "ml-topK (K = 2, 3, ...)"
        )
    return functools.partial(_most_likely_of_named_top, name)


def default_point_forecast(config: ExperimentConfig) -> str:
    """The point forecast to use when none is named: the one stored with the trained model
    (``ExperimentConfig.point_forecast``, chosen after training on validation and development
    data), else ``ml-top10`` for a velocity-residual decoder and ``ml-argmax`` (the fastest)
    otherwise. On recordings from elsewhere each is its kind's best or level with it, and the
    other kind's choice fails there: the residual Trajectron++'s argmax latent is at
    1.02-1.04x constant velocity's FDE pooled on the development set (its ``ml-top10`` at
    0.90-0.93x), plain Trajectron++'s ``ml-top10`` up to 1.30x with 25+ neighbours
    (benchmarks/RESULTS.md)."""
    if config.point_forecast:
        return config.point_forecast
    return "ml-top10" if config.model.velocity_residual else "ml-argmax"
