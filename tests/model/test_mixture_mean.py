"""The mean forecast: the p(z|x)-weighted mean of the latent values' trajectories."""

from __future__ import annotations

import math

import torch

from grouptron.model.cvae import Encoding, VelocityGaussians
from grouptron.model.predict import mixture_mean_positions, most_likely_positions


def _two_latent_values() -> tuple[Encoding, VelocityGaussians]:
    """One sample, two latent values with weights 1/4 and 3/4: walk east at 1 m/s or north at
    1 m/s for 3 steps, the second far more certain (small sigma)."""
    H = 3
    mean = torch.zeros(1, 2, H, 2)
    mean[0, 0, :, 0] = 1.0  # east
    mean[0, 1, :, 1] = 1.0  # north
    log_sigma = torch.zeros(1, 2, H, 2)
    log_sigma[0, 1] = math.log(0.01)
    encoding = Encoding(
        x=torch.zeros(1, 4), p_logits=torch.tensor([[0.0, math.log(3.0)]]), q_logits=None
    )
    gaussians = VelocityGaussians(mean, log_sigma, torch.zeros(1, 2, H), mean.clone())
    return encoding, gaussians


def test_the_mean_weights_every_latent_value_by_its_probability() -> None:
    encoding, velocity = _two_latent_values()
    positions = mixture_mean_positions(encoding, velocity, dt_s=0.4)  # (1, 3, 2)
    steps = torch.arange(1, 4, dtype=torch.float32) * 0.4  # metres walked at 1 m/s
    expected = torch.stack([0.25 * steps, 0.75 * steps], dim=-1)[None]
    torch.testing.assert_close(positions, expected)


def test_the_mode_follows_the_sharp_latent_value_and_the_mean_does_not() -> None:
    encoding, velocity = _two_latent_values()
    mode = most_likely_positions(encoding, velocity, horizon=3, dt_s=0.4)
    mean = mixture_mean_positions(encoding, velocity, dt_s=0.4)
    assert mode[0, -1, 0].abs() < 1e-3 and mode[0, -1, 1] > 1.1  # all north
    assert mean[0, -1, 0] > 0.25  # a quarter east
