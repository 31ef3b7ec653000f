"""Prediction regions hold the probability they state, of one Gaussian and of mixtures."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.model.mixture import Mixture
from grouptron.model.regions import Regions, prediction_regions


def _one_gaussian(q: float) -> tuple[Regions, np.ndarray]:
    """Regions of a single Gaussian centred on the forecast, and its covariance."""
    rng = np.random.default_rng(0)
    cov = np.array([[2.0, 0.3], [0.3, 0.5]])
    means = rng.normal(size=(3, 1, 12, 2))
    covs = np.broadcast_to(cov, (3, 1, 12, 2, 2))
    return prediction_regions(means[:, 0], Mixture(np.zeros((3, 1)), means, covs), q), cov


@pytest.mark.parametrize("q", [0.5, 0.9, 0.95])
def test_one_centred_gaussian_gives_the_chi_square_ellipse(q: float) -> None:
    regions, cov = _one_gaussian(q)
    variances, vectors = np.linalg.eigh(cov)  # ascending
    radius = np.sqrt(-2.0 * np.log(1.0 - q))  # the 2-dof chi-square quantile, square-rooted
    np.testing.assert_allclose(regions.major_m, radius * np.sqrt(variances[1]), rtol=2e-3)
    np.testing.assert_allclose(regions.minor_m, radius * np.sqrt(variances[0]), rtol=2e-3)
    major_direction = vectors[:, 1]
    angle = np.arctan(major_direction[1] / major_direction[0])
    np.testing.assert_allclose(regions.angle_rad, angle, atol=1e-9)


def _draws(weights: np.ndarray, means: np.ndarray, covs: np.ndarray, count: int) -> np.ndarray:
    """(count, H, 2) draws from one forecast's (M,) mixture of (M, H) Gaussians."""
    rng = np.random.default_rng(1)
    component = rng.choice(len(weights), size=count, p=weights)
    factor = np.linalg.cholesky(covs)[component]  # (count, H, 2, 2)
    noise = rng.standard_normal((count, means.shape[1], 2))
    return means[component] + np.einsum("khij,khj->khi", factor, noise)


@pytest.mark.parametrize("q", [0.5, 0.9])
def test_a_mixture_region_holds_its_probability(q: float) -> None:
    """Draws from skewed mixtures of 10 Gaussians fall inside at rate q (within sampling
    error), although the ellipse is centred on a point that is not the mixture's mean."""
    rng = np.random.default_rng(2)
    N, M, H = 6, 10, 12
    means = rng.normal(size=(N, M, H, 2)) * 0.5
    spread = rng.normal(size=(N, M, H, 2, 2)) * 0.3
    covs = spread @ spread.swapaxes(-1, -2) + 0.01 * np.eye(2)
    log_weights = rng.normal(size=(N, M))
    centre = means[:, 0]  # the most probable component's mean, say
    regions = prediction_regions(centre, Mixture(log_weights, means, covs), q)
    weights = np.exp(log_weights) / np.exp(log_weights).sum(axis=1, keepdims=True)
    count = 20_000
    for n in range(N):
        draws = _draws(weights[n], means[n], covs[n], count)
        one = Regions(
            q,
            *(np.broadcast_to(a[n], (count, *a.shape[1:])) for a in (centre,)),
            *(np.broadcast_to(a[n], (count, H)) for a in (regions.major_m, regions.minor_m)),
            np.broadcast_to(regions.angle_rad[n], (count, H)),
        )
        share = one.contains(draws).mean(axis=0)  # (H,)
        assert np.all(np.abs(share - q) < 0.02), (n, share)


def test_regions_grow_with_their_probability_and_no_forecast_gives_none() -> None:
    small, _ = _one_gaussian(0.5)
    large, _ = _one_gaussian(0.9)
    assert np.all(large.major_m > small.major_m) and np.all(large.minor_m > small.minor_m)
    empty = prediction_regions(np.zeros((0, 12, 2)), Mixture.empty(3, 12), 0.9)
    assert empty.major_m.shape == (0, 12)
