"""Cluster-bootstrap intervals on hand-made cases."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.evaluation.evaluate import SampleScores
from grouptron.evaluation.results import EvaluationResult, mean_over_splits, score_rows
from grouptron.evaluation.uncertainty import (
    bootstrap_means,
    column_intervals,
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


def test_intervals_per_column_are_those_of_each_column_alone() -> None:
    """Per step (a column each) as for one mean, and for the average over splits as the
    report's AVG: the same resamples."""
    rng = np.random.default_rng(1)
    splits = [(rng.normal(size=(40, 3)), rng.integers(0, 9, 40)) for _ in range(2)]
    values, steps = splits[0]
    for column, found in enumerate(column_intervals([(values, steps)])):
        alone = mean_interval(values[:, column], steps)
        assert (found.mean, found.low, found.high) == pytest.approx(
            (alone.mean, alone.low, alone.high)
        )
    averaged = column_intervals(splits)[2]
    expected = split_average_interval([(v[:, 2], t) for v, t in splits])
    assert (averaged.low, averaged.high) == pytest.approx((expected.low, expected.high))


def test_every_mean_of_a_row_and_of_the_mean_over_splits_has_its_interval() -> None:
    rng = np.random.default_rng(2)
    scored = []
    for count in (30, 50):
        values = {name: rng.uniform(0, 2, count) for name in ("ade", "fde", "miss-rate-2m")}
        per_step = {"displacement": rng.uniform(0, 2, (count, 12))}
        scored.append((SampleScores("best-of-5", values, per_step), rng.integers(0, 6, count)))
    template = EvaluationResult("eth", "grouptron", None, 0, 0.0, 0.0)
    rows = [score_rows(template, s, {None: None}, steps=t)[0] for s, t in scored]
    mean = mean_over_splits(rows, scored)
    for row in (*rows, mean):
        assert row.ade_ci is not None and row.ade_ci[0] <= row.ade <= row.ade_ci[1]
        assert row.fde_ci is not None and row.fde_ci[0] <= row.fde <= row.fde_ci[1]
        low, high = row.metrics_ci["miss-rate-2m"]
        assert low <= row.metrics["miss-rate-2m"] <= high
        assert len(row.per_step_ci["displacement"]) == 12
        as_json = row.to_dict()
        assert len(as_json["displacement_per_step_ci"]) == 12  # type: ignore[arg-type]
        assert "miss-rate-2m_ci" in as_json
    expected = split_average_interval([(s.fde, t) for s, t in scored])
    assert mean.fde_ci == pytest.approx((expected.low, expected.high))
    assert mean_over_splits(rows).fde_ci is None  # without the scores: no interval
