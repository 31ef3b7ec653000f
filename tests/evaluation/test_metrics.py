"""Golden values for the displacement metrics and the KDE NLL."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import gaussian_kde

from grouptron.evaluation.metrics import (
    ade,
    displacement_errors,
    fde,
    kde_log_density,
    kde_nll,
    min_ade_k,
    min_fde_k,
)

TRUTH = np.zeros((3, 2))  # a pedestrian standing at the origin for 3 steps


def test_stationary_truth_against_a_3_4_5_offset() -> None:
    pred = np.array([[3.0, 4.0], [0.0, 0.0], [6.0, 8.0]])
    np.testing.assert_allclose(displacement_errors(pred, TRUTH), [5.0, 0.0, 10.0])
    assert ade(pred, TRUTH) == pytest.approx(5.0)
    assert fde(pred, TRUTH) == pytest.approx(10.0)


def test_batched_shapes() -> None:
    pred = np.ones((4, 5, 12, 2))
    truth = np.zeros((4, 5, 12, 2))
    assert ade(pred, truth).shape == (4, 5)
    np.testing.assert_allclose(fde(pred, truth), np.sqrt(2))


def test_min_over_k_takes_ade_and_fde_minima_independently() -> None:
    truth = np.zeros((1, 2, 2))
    good_start = np.array([[0.0, 0.0], [4.0, 0.0]])  # ADE 2, FDE 4
    good_end = np.array([[5.0, 0.0], [1.0, 0.0]])  # ADE 3, FDE 1
    samples = np.stack([good_start, good_end])[None]  # (1, 2, 2, 2)
    assert min_ade_k(samples, truth)[0] == pytest.approx(2.0)
    assert min_fde_k(samples, truth)[0] == pytest.approx(1.0)


def test_kde_log_density_matches_scipy() -> None:
    rng = np.random.default_rng(0)
    for num in (5, 50, 2000):
        points = rng.normal(size=(num, 2)) @ np.array([[1.0, 0.3], [0.0, 0.5]]) + [2.0, -1.0]
        query = rng.normal(size=2)
        expected = gaussian_kde(points.T).logpdf(query[:, None])[0]
        assert kde_log_density(points, query) == pytest.approx(expected, rel=1e-9)


def test_kde_nll_clips_each_step_at_minus_20_and_averages() -> None:
    rng = np.random.default_rng(1)
    samples = rng.normal(size=(2, 100, 3, 2))  # (B, K, H, 2)
    truth = np.zeros((2, 3, 2))
    truth[1, 2] = [1e3, 1e3]  # hopeless at one step: log-density clipped to -20
    nll = kde_nll(samples, truth)
    per_step = np.array(
        [
            [gaussian_kde(samples[b, :, h].T).logpdf(truth[b, h][:, None])[0] for h in range(3)]
            for b in range(2)
        ]
    )
    expected = -np.maximum(per_step, -20.0).mean(axis=1)
    np.testing.assert_allclose(nll, expected, rtol=1e-9)
    assert per_step[1, 2] < -20.0


def test_kde_nll_is_nan_for_identical_predictions() -> None:
    samples = np.zeros((1, 10, 2, 2))
    assert np.isnan(kde_nll(samples, np.zeros((1, 2, 2))))[0]
