"""The CVAE's forecasting engine: what a trained CVAE predicts for a batch. :func:`decode`
makes a point forecast (any :class:`PointForecast`) with the Gaussians it was made from and,
when asked, those of every latent value; :func:`predict_samples` draws futures. The CVAE's
forecaster methods (``TrajectronCVAE.forecast_point``, ``forecast_futures``) are these, and
every path that forecasts (the Python API, live sessions, whole files, calibration,
evaluation, export) calls those, so that one forecast is made one way."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import torch

from grouptron import constants
from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch
from grouptron.model.cvae_outputs import Encoding, VelocityGaussians
from grouptron.model.forecaster import (
    Gaussians,
    is_outside_name,
    latent_values_of,
    outside_forecaster,
)
from grouptron.model.gaussians import position_covariances, positions_from_velocities
from grouptron.model.mixture_mode import mixture_mode
from grouptron.point_forecast import PointForecast

if TYPE_CHECKING:
    from grouptron.model.cvae import TrajectronCVAE

ABLATIONS = constants.ABLATIONS
"""Inputs an evaluation can take away to see what a model uses: ``edges`` zeroes the
neighbour input of the edge encoder, ``scene`` zeroes Grouptron's scene encoding E_scene."""
Ablation = tuple[str, ...]


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


def mixture_mean_positions(
    encoding: Encoding, velocity: VelocityGaussians, dt_s: float
) -> torch.Tensor:
    """(B, H, 2): the ``encoding.p_logits``-weighted mean of the (B, M, H, 2) decoded velocity
    means, integrated (integration is linear, so this is the mean of the positions)."""
    weights = torch.softmax(encoding.p_logits, dim=-1)  # (B, M)
    mean_velocity = (weights[:, :, None, None] * velocity.mean).sum(dim=1)  # (B, H, 2)
    return positions_from_velocities(mean_velocity, dt_s).float()


def mode_starts(decoded: int, latent_values: int) -> int:
    """Climbs per mixture for the mode of ``decoded`` of a model's ``latent_values`` latent
    values: the benchmark's :data:`MODE_STARTS` for all of them, :data:`TOP_MODE_STARTS` for
    fewer."""
    return TOP_MODE_STARTS if decoded < latent_values else MODE_STARTS


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
    decoded latent values, as :func:`decode` makes ``ml-topK`` (all Z: ``ml``)."""
    Z, horizon = velocity.mean.shape[1], velocity.mean.shape[2]
    top = top_latent_values(encoding, velocity, latent_values)
    return most_likely_positions(*top, horizon, dt_s, mode_starts(latent_values, Z))


def _gaussians(encoding: Encoding, velocity: VelocityGaussians, dt_s: float) -> Gaussians:
    """The decoded latent values' velocity Gaussians as position Gaussians."""
    return Gaussians(
        log_weights=torch.log_softmax(encoding.p_logits, dim=-1),
        means=positions_from_velocities(velocity.mean, dt_s),
        covariances=position_covariances(velocity.cov, dt_s),
    )


@dataclasses.dataclass(frozen=True)
class Decoded:
    """A batch's point forecast and what it was made from, relative to ``t``.

    Attributes:
        point: (B, H, 2) the point forecast's positions.
        encoding, velocity: p(z|x) and the velocity Gaussians of the M latent values it was
            made from (most probable first; all Z for ``ml`` and ``mean``).
        every: those of all Z latent values, when asked for (else None).
        dt_s: seconds per step.
    """

    point: torch.Tensor
    encoding: Encoding
    velocity: VelocityGaussians
    every: tuple[Encoding, VelocityGaussians] | None
    dt_s: float

    def distribution(self) -> Gaussians:
        """The position Gaussians the point forecast was made from."""
        return _gaussians(self.encoding, self.velocity, self.dt_s)

    def mixture(self) -> Gaussians | None:
        """The position Gaussians of all Z latent values (None when not decoded)."""
        return None if self.every is None else _gaussians(*self.every, self.dt_s)


def decode(
    model: TrajectronCVAE,
    batch: Batch,
    forecast: PointForecast,
    horizon: int,
    dt_s: float,
    *,
    every: bool = False,
    ablate: Ablation = (),
) -> Decoded:
    """The point forecast ``forecast`` of a batch, decoding only the latent values it reads
    (all Z with ``every``, from which the same forecast is made)."""
    Z = model.config.latent_values
    M = forecast.latent_values(Z)
    encoding = encode_prior(model, batch, ablate)
    if every or M == Z:
        velocity = model.decode(encoding.x, batch.state_now_st, None, horizon, feedback="mean")
        whole = (encoding, velocity)
        if M < Z:
            encoding, velocity = top_latent_values(encoding, velocity, M)
    else:
        whole = None
        logits, z_index = encoding.p_logits.topk(M, dim=-1)  # (B, M), most probable first
        encoding = Encoding(x=encoding.x, p_logits=logits, q_logits=None)
        velocity = model.decode(encoding.x, batch.state_now_st, z_index, horizon, feedback="mean")
    if forecast.kind == "mean":
        point = mixture_mean_positions(encoding, velocity, dt_s)
    else:
        point = most_likely_positions(encoding, velocity, horizon, dt_s, mode_starts(M, Z))
    return Decoded(point, encoding, velocity, whole if every else None, dt_s)


def predict_point(
    model: TrajectronCVAE,
    batch: Batch,
    forecast: PointForecast,
    horizon: int,
    dt_s: float,
    ablate: Ablation = (),
) -> torch.Tensor:
    """(B, H, 2) the point forecast ``forecast`` relative to ``t`` (:func:`decode`'s)."""
    return decode(model, batch, forecast, horizon, dt_s, ablate=ablate).point


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


def default_point_forecast(config: ExperimentConfig) -> PointForecast:
    """The point forecast to use when none is named: the one stored with the trained model
    (``ExperimentConfig.point_forecast``, chosen after training on validation and development
    data), else ``ml-top10`` for a velocity-residual decoder and ``ml-argmax`` (the fastest)
    otherwise. On recordings from elsewhere each is its kind's best or level with it, and the
    other kind's choice fails there: the residual Trajectron++'s argmax latent is at
    1.02-1.04x constant velocity's FDE pooled on the development set (its ``ml-top10`` at
    0.90-0.93x), plain Trajectron++'s ``ml-top10`` up to 1.30x with 25+ neighbours
    (benchmarks/RESULTS.md)."""
    if config.point_forecast:
        named = PointForecast.parse(config.point_forecast)
    elif is_outside_name(config.model_name):  # a model of the forecaster interface
        return PointForecast.parse(outside_forecaster(config.model_name).point_forecasts[0])
    else:
        named = PointForecast("ml", 10 if config.model.velocity_residual else 1)
    return named.for_model(latent_values_of(config))
