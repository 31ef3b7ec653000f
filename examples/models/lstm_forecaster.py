"""An LSTM encoder-decoder that grouptron trains, evaluates and serves without a change to the
package: the worked example of docs/models.md.

    grouptron train --model lstm_forecaster:LSTMForecaster --split eth

The encoder reads a person's standardised history; the decoder is one linear map from its last
state to a Gaussian per future step (position offset from now, metres, and an isotropic spread),
so its most likely forecast is its mean and its distribution has one component.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from grouptron.config import ExperimentConfig
from grouptron.model.batch import Batch
from grouptron.model.forecaster import Forecaster, GaussianPoint, Gaussians, Loss, TrainingStep
from grouptron.point_forecast import PointForecast


@dataclass(frozen=True)
class Settings:
    """``--set model_settings.NAME=VALUE``: stored with the weights, read back on loading."""

    hidden: int = 64
    min_sigma_m: float = 0.05


class LSTMForecaster(Forecaster):
    """History LSTM -> per-step Gaussians of the position relative to now."""

    point_forecasts = ("ml", "mean")  # one Gaussian per step: its mode is its mean

    def __init__(self, config: ExperimentConfig) -> None:
        super().__init__()
        self.settings = Settings(**config.model_settings)
        self.horizon = config.data.horizon_steps
        self.encoder = nn.LSTM(6, self.settings.hidden, batch_first=True)
        self.head = nn.Linear(self.settings.hidden, 3 * self.horizon)  # dx, dy, log sigma

    def gaussians(self, batch: Batch) -> tuple[torch.Tensor, torch.Tensor]:
        """(B, H, 2) mean positions relative to now and (B, H) standard deviations, metres."""
        _, (state, _) = self.encoder(batch.hist_st.float())  # (1, B, hidden)
        out = self.head(state[-1]).view(-1, self.horizon, 3)
        mean = out[..., :2].cumsum(dim=1)  # a step's offset adds to the last one's
        sigma = self.settings.min_sigma_m + nn.functional.softplus(out[..., 2])
        return mean, sigma

    def training_loss(self, batch: Batch, step: TrainingStep) -> Loss:
        """The Gaussian negative log-likelihood of the true future, summed over the steps."""
        mean, sigma = self.gaussians(batch)
        squared = ((batch.fut_rel_m - mean) ** 2).sum(dim=-1)  # (B, H)
        nll = (squared / (2 * sigma**2) + 2 * torch.log(sigma)).sum(dim=-1)  # (B,)
        error = squared.sqrt().mean(dim=-1)
        return Loss(step.batch_mean(nll), {"ade": step.batch_mean(error.detach())})

    def sample(
        self,
        batch: Batch,
        horizon: int,
        dt_s: float,
        num_samples: int,
        generator: torch.Generator | None = None,
    ) -> torch.Tensor:
        """(B, K, H, 2) draws of the per-step Gaussians."""
        mean, sigma = self.gaussians(batch)
        shape = (len(mean), num_samples, *mean.shape[1:])
        noise = torch.randn(shape, generator=generator, device=mean.device)
        return mean[:, None] + sigma[:, None, :, None] * noise

    def point(
        self, batch: Batch, forecast: PointForecast, horizon: int, dt_s: float
    ) -> GaussianPoint:
        """The mean, with the Gaussians as its distribution (regions are drawn from them)."""
        mean, sigma = self.gaussians(batch)
        variance = sigma**2
        entries = torch.stack([variance, torch.zeros_like(variance), variance], dim=-1)
        return GaussianPoint(
            point=mean,
            gaussians=Gaussians(
                log_weights=torch.zeros(len(mean), 1, device=mean.device),
                means=mean[:, None],
                covariances=entries[:, None],  # (B, 1, H, 3)
            ),
        )
