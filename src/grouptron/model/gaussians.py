"""Bivariate Gaussians over velocity, their integration to positions, and mixtures of them.

Pure functions on ``...`` leading dimensions. A covariance is stored as its three distinct
entries ``(var_x, cov_xy, var_y)`` in the last axis.
"""

from __future__ import annotations

import math

import torch

LOG_2PI = math.log(2.0 * math.pi)


def covariance_entries(log_sigma: torch.Tensor, corr: torch.Tensor) -> torch.Tensor:
    """(..., 2) log standard deviations and (...) correlations -> (..., 3) covariance entries."""
    sigma = log_sigma.exp()
    return torch.stack(
        [sigma[..., 0] ** 2, corr * sigma[..., 0] * sigma[..., 1], sigma[..., 1] ** 2], dim=-1
    )


def covariance_matrices(entries: torch.Tensor) -> torch.Tensor:
    """(..., 3) covariance entries -> (..., 2, 2) symmetric matrices."""
    var_x, cov_xy, var_y = entries.unbind(-1)
    return torch.stack([torch.stack([var_x, cov_xy], -1), torch.stack([cov_xy, var_y], -1)], -2)


def log_prob(points: torch.Tensor, mean: torch.Tensor, cov: torch.Tensor) -> torch.Tensor:
    """Bivariate Gaussian log-density: (..., 2) points, (..., 2) means, (..., 3) cov -> (...)."""
    var_x, cov_xy, var_y = cov.unbind(-1)
    det = var_x * var_y - cov_xy**2
    dx, dy = (points - mean).unbind(-1)
    maha = (var_y * dx**2 - 2.0 * cov_xy * dx * dy + var_x * dy**2) / det
    return -LOG_2PI - 0.5 * torch.log(det) - 0.5 * maha


def sample(
    mean: torch.Tensor,
    log_sigma: torch.Tensor,
    corr: torch.Tensor,
    generator: torch.Generator | None = None,
    *,
    eps: torch.Tensor | None = None,
) -> torch.Tensor:
    """A reparameterised draw ``mean + L eps`` with ``L`` the Cholesky factor: (..., 2); ``eps``
    (standard normals shaped like ``mean``) is drawn from ``generator`` unless given."""
    if eps is None:
        eps = torch.randn(mean.shape, generator=generator, dtype=mean.dtype, device=mean.device)
    else:
        eps = eps.to(mean.dtype)
    sigma = log_sigma.exp()
    e_x, e_y = eps.unbind(-1)
    x = sigma[..., 0] * e_x
    y = sigma[..., 1] * (corr * e_x + torch.sqrt(1.0 - corr**2) * e_y)
    return mean + torch.stack([x, y], dim=-1)


def positions_from_velocities(vel: torch.Tensor, dt_s: float) -> torch.Tensor:
    """(..., H, 2) velocities (m/s) -> (..., H, 2) positions relative to the current one:
    ``pos_k = dt * sum_{j<=k} v_j`` (single-integrator dynamics, the one integration rule)."""
    return torch.cumsum(vel, dim=-2) * dt_s


def position_covariances(vel_cov: torch.Tensor, dt_s: float) -> torch.Tensor:
    """(..., H, 3) velocity covariance entries -> position covariances: ``dt^2 Sigma_v``
    accumulated per step (the steps' velocities independent, as in the reference)."""
    return torch.cumsum(vel_cov, dim=-2) * dt_s**2


def integrate_single_integrator(
    vel_mean: torch.Tensor, vel_cov: torch.Tensor, dt_s: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """Positions from per-step velocity Gaussians (single-integrator dynamics).

    ``pos_k = pos_t + dt * sum_{j<=k} v_j``; the covariance accumulates ``dt^2 Sigma_v`` per step
    (the steps' velocities are treated as independent, as in the reference).

    Args:
        vel_mean: (..., H, 2) velocity means, m/s.
        vel_cov: (..., H, 3) velocity covariance entries.
        dt_s: seconds per step.

    Returns:
        (..., H, 2) position means relative to ``pos_t`` and (..., H, 3) their covariances.
    """
    return positions_from_velocities(vel_mean, dt_s), position_covariances(vel_cov, dt_s)


def mixture_log_prob(
    points: torch.Tensor, log_weights: torch.Tensor, mean: torch.Tensor, cov: torch.Tensor
) -> torch.Tensor:
    """Log-density of Gaussian mixtures over the component axis -2 of ``mean``.

    Args:
        points: (..., 2).
        log_weights: (..., Z) normalised log mixture weights.
        mean: (..., Z, 2); cov: (..., Z, 3).

    Returns:
        (...) log-densities.
    """
    component = log_prob(points[..., None, :], mean, cov)  # (..., Z)
    return torch.logsumexp(log_weights + component, dim=-1)
