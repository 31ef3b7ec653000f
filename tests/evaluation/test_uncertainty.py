"""Cluster-bootstrap intervals on hand-made cases."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.evaluation.uncertainty import (
    bootstrap_means,
    mean_interval,
    seed_spread,
    split_average_interval,
)


def test_identical_clusters_give_a_zero_width_interval() -> None:
    values = np.array([1.0, 3.0, 1.0, 3.0, 1.0, 3.0])  # every step has mean 2
    clusters = np.array([0, 0, 1, 1, 2, 2])
    result = mean_interval(values, clusters)
    assert result.mean == pytest.approx(2.0)
    assert result.low == pytest.approx(2.0) and result.high == pytest.approx(2.0)


def test_resampling_whole_steps_widens_the_interval_of_correlated_samples() -> None:
    """Two steps of 50 identical samples each: 2 independent observations, not 100."""
    values = np.r_[np.zeros(50), np.ones(50)]
    steps = np.r_[np.zeros(50), np.ones(50)]
    by_step = mean_interval(values, steps)
    by_sample = mean_interval(values, np.arange(100))
    assert by_step.high - by_step.low > 0.9  # a resample is all-0, all-1 or half-half
    assert by_sample.high - by_sample.low < 0.3


def test_the_interval_matches_the_normal_approximation_for_independent_steps() -> None:
    rng = np.random.default_rng(1)
    values = rng.normal(1.0, 0.5, 4000)
    result = mean_interval(values, np.arange(4000), replicates=4000)
    half_width = 1.96 * 0.5 / np.sqrt(4000)
    assert result.high - result.low == pytest.approx(2 * half_width, rel=0.1)
    assert result.low < result.mean < result.high


def test_equal_seeds_resample_the_same_steps() -> None:
    clusters = np.repeat(np.arange(10), 3)
    a = bootstrap_means(np.arange(30.0), clusters, 50, seed=4)
    b = bootstrap_means(np.arange(30.0), clusters, 50, seed=4)
    np.testing.assert_array_equal(a, b)


def test_split_average_is_the_mean_of_split_means() -> None:
    first = (np.array([1.0, 1.0, 1.0]), np.array([0, 1, 2]))
    second = (np.array([3.0, 5.0]), np.array([0, 0]))  # one step: no spread
    result = split_average_interval([first, second])
    assert result.mean == pytest.approx((1.0 + 4.0) / 2)
    assert result.low == pytest.approx(2.5) and result.high == pytest.approx(2.5)


def test_seed_spread() -> None:
    assert seed_spread([1.0, 2.0, 3.0]) == pytest.approx((2.0, 1.0))
    assert np.isnan(seed_spread([1.0])[1])
