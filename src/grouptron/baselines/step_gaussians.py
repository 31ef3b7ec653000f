"""Independent bivariate Gaussians of each future step's displacement: the output of the
learned baselines (Social-STGCNN's, and the small Transformer's), as Social-STGCNN defines it.

A network gives five numbers per step: the mean displacement (x, y) in metres, two spreads and
a correlation. The steps are independent, so a position (the sum of the displacements up to
its step) is Gaussian too, with the summed means and covariances: the most likely forecast is
the mean path, and its distribution is exact, not drawn.

Shapes: ``B`` samples, ``K`` draws, ``H`` steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from grouptron.model.batch import Batch
from grouptron.model.forecaster import (
    Forecaster,
    GaussianPoint,
    Gaussians,
    Loss,
    TrainingStep,
)
from grouptron.point_forecast import PointForecast

RAW_VALUES = 5
"""Numbers a network gives per step: mean x, mean y, two spreads before softplus, the
correlation before tanh."""

MAX_CORRELATION = 0.99
"""The correlation is kept inside (-0.99, 0.99), so that a covariance never turns singular."""


@dataclass(frozen=True)
class StepGaussians:
    """Each step's displacement as a bivariate Gaussian.

    Attributes:
        mean_m: (B, H, 2) mean displacement of each step, metres.
        sigma_m: (B, H, 2) its standard deviations along x and y, metres.
        correlation: (B, H) the correlation of x and y.
    """

    mean_m: torch.Tensor
    sigma_m: torch.Tensor
    correlation: torch.Tensor

    @classmethod
    def from_raw(cls, raw: torch.Tensor, min_sigma_m: float) -> StepGaussians:
        """From a network's (B, H, 5) output: spreads through softplus above ``min_sigma_m``,
        the correlation through tanh."""
        sigma = min_sigma_m + nn.functional.softplus(raw[..., 2:4])
        return cls(raw[..., :2], sigma, MAX_CORRELATION * torch.tanh(raw[..., 4]))

    def step_covariances(self) -> torch.Tensor:
        """(B, H, 3) each step's covariance entries (var_x, cov_xy, var_y), m^2."""
        sx, sy = self.sigma_m[..., 0], self.sigma_m[..., 1]
        return torch.stack([sx**2, self.correlation * sx * sy, sy**2], dim=-1)

    def negative_log_likelihood(self, fut_rel_m: torch.Tensor) -> torch.Tensor:
        """(B,) the NLL of the (B, H, 2) true future (positions relative to now) in nats,
        summed over the steps: each step's displacement under its Gaussian."""
        start = torch.zeros_like(fut_rel_m[:, :1])
        steps = fut_rel_m - torch.cat([start, fut_rel_m[:, :-1]], dim=1)  # (B, H, 2)
        z = (steps - self.mean_m) / self.sigma_m  # (B, H, 2)
        rho = self.correlation
        one_minus = 1.0 - rho**2
        quadratic = (z[..., 0] ** 2 - 2 * rho * z[..., 0] * z[..., 1] + z[..., 1] ** 2) / one_minus
        log_norm = torch.log(2 * torch.pi * self.sigma_m.prod(dim=-1) * torch.sqrt(one_minus))
        nll: torch.Tensor = (0.5 * quadratic + log_norm).sum(dim=-1)
        return nll

    def sample(self, num_samples: int, generator: torch.Generator | None) -> torch.Tensor:
        """(B, K, H, 2) paths relative to now: every step's displacement drawn, then summed."""
        B, H = self.mean_m.shape[:2]
        noise = torch.randn(
            (B, num_samples, H, 2), generator=generator, device=self.mean_m.device
        ).to(self.mean_m.dtype)
        rho = self.correlation[:, None]  # (B, 1, H)
        sx, sy = self.sigma_m[:, None, :, 0], self.sigma_m[:, None, :, 1]
        dx = sx * noise[..., 0]
        dy = sy * (rho * noise[..., 0] + torch.sqrt(1 - rho**2) * noise[..., 1])
        steps = self.mean_m[:, None] + torch.stack([dx, dy], dim=-1)
        return steps.cumsum(dim=2)

    def point(self) -> GaussianPoint:
        """The mean path (the most likely: one Gaussian per step), with the exact Gaussian of
        every position (summed means and covariances) as its distribution."""
        path = self.mean_m.cumsum(dim=1)  # (B, H, 2)
        covariances = self.step_covariances().cumsum(dim=1)  # (B, H, 3)
        return GaussianPoint(
            point=path,
            gaussians=Gaussians(
                log_weights=torch.zeros(len(path), 1, dtype=path.dtype, device=path.device),
                means=path[:, None],
                covariances=covariances[:, None],  # (B, 1, H, 3)
            ),
        )


class StepGaussianForecaster(Forecaster):
    """A forecaster whose network gives :class:`StepGaussians`: trained by their negative
    log-likelihood, sampled step by step, its point forecast the mean path."""

    point_forecasts = ("ml", "mean")  # one Gaussian per step: its mode is its mean

    def step_gaussians(self, batch: Batch) -> StepGaussians:
        """The (B, H) step Gaussians of ``batch``'s people."""
        raise NotImplementedError

    def training_loss(self, batch: Batch, step: TrainingStep) -> Loss:
        """The negative log-likelihood of the true future's displacements."""
        gaussians = self.step_gaussians(batch)
        nll = gaussians.negative_log_likelihood(batch.fut_rel_m.float())
        error = (gaussians.point().point - batch.fut_rel_m).norm(dim=-1).mean(dim=-1)
        return Loss(step.batch_mean(nll), {"ade": step.batch_mean(error.detach())})

    def sample(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        num_samples: int,
        generator: torch.Generator | None = None,
    ) -> torch.Tensor:
        """(B, K, H, 2) paths drawn step by step."""
        return self.step_gaussians(batch).sample(num_samples, generator)

    def point(
        self, batch: Batch, forecast: PointForecast, horizon: int, dt_s: float
    ) -> GaussianPoint:
        """The mean path with its exact Gaussians."""
        return self.step_gaussians(batch).point()
