"""Bivariate Gaussians, their integration, and mixtures, against torch.distributions."""

from __future__ import annotations

import torch
from torch.distributions import MultivariateNormal

from grouptron.model import gaussians


def random_gaussians(n: int, seed: int = 0) -> tuple[torch.Tensor, ...]:
    g = torch.Generator().manual_seed(seed)
    mean = torch.randn(n, 2, generator=g, dtype=torch.float64)
    log_sigma = torch.randn(n, 2, generator=g, dtype=torch.float64) * 0.5
    corr = torch.tanh(torch.randn(n, generator=g, dtype=torch.float64))
    return mean, log_sigma, corr


def full_matrix(cov: torch.Tensor) -> torch.Tensor:
    return torch.stack([cov[..., [0, 1]], cov[..., [1, 2]]], -2)


def test_log_prob_matches_torch() -> None:
    mean, log_sigma, corr = random_gaussians(50)
    cov = gaussians.covariance_entries(log_sigma, corr)
    points = torch.randn(50, 2, dtype=torch.float64)
    expected = MultivariateNormal(mean, full_matrix(cov)).log_prob(points)
    torch.testing.assert_close(gaussians.log_prob(points, mean, cov), expected)


def test_samples_have_the_right_moments() -> None:
    mean, log_sigma, corr = (t[:1].expand(200_000, *t.shape[1:]) for t in random_gaussians(1, 3))
    draws = gaussians.sample(mean, log_sigma, corr, torch.Generator().manual_seed(0))
    cov = gaussians.covariance_entries(log_sigma[:1], corr[:1])[0]
    empirical = torch.cov(draws.T)
    torch.testing.assert_close(draws.mean(0), mean[0], atol=0.02, rtol=0)
    torch.testing.assert_close(empirical, full_matrix(cov), atol=0.03, rtol=0.03)


def test_single_integrator_accumulates_mean_and_covariance() -> None:
    vel = torch.tensor([[1.0, 0.0], [1.0, 2.0], [0.0, -1.0]])
    cov = torch.tensor([[1.0, 0.0, 4.0], [2.0, 1.0, 1.0], [1.0, 0.0, 1.0]])
    pos, pos_cov = gaussians.integrate_single_integrator(vel, cov, dt_s=0.5)
    torch.testing.assert_close(pos, torch.tensor([[0.5, 0.0], [1.0, 1.0], [1.0, 0.5]]))
    torch.testing.assert_close(
        pos_cov, torch.tensor([[0.25, 0.0, 1.0], [0.75, 0.25, 1.25], [1.0, 0.25, 1.5]])
    )


def test_mixture_log_prob_is_the_weighted_sum() -> None:
    mean, log_sigma, corr = random_gaussians(3, 7)
    cov = gaussians.covariance_entries(log_sigma, corr)
    weights = torch.tensor([0.2, 0.5, 0.3], dtype=torch.float64)
    point = torch.tensor([0.3, -0.2], dtype=torch.float64)
    density = sum(
        w * MultivariateNormal(m, full_matrix(c)).log_prob(point).exp()
        for w, m, c in zip(weights, mean, cov, strict=True)
    )
    got = gaussians.mixture_log_prob(point, weights.log(), mean, cov)
    torch.testing.assert_close(got, torch.log(torch.as_tensor(density)))
