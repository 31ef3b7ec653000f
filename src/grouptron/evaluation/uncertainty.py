"""How sure a score is: bootstrap confidence intervals that resample time steps.

Samples of one (scene, step) share the scene and its people, so they are not independent;
resampling individual samples would make intervals too narrow. Every function here resamples
whole time steps ("clusters") with replacement and recomputes the sample mean, the usual
cluster bootstrap. Paired differences between two models are bootstrapped the same way on the
per-sample differences, so both models see the same resampled steps. Pure NumPy, no state.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

REPLICATES = 2000
LEVEL = 0.95


@dataclass(frozen=True)
class Interval:
    """A mean and its (level) percentile-bootstrap confidence interval."""

    mean: float
    low: float
    high: float

    def to_list(self) -> list[float]:
        """``[low, high]``, the interval's bounds."""
        return [self.low, self.high]

    def excludes_zero(self) -> bool:
        """Whether the interval lies strictly above or strictly below zero."""
        return self.low > 0.0 or self.high < 0.0

    def signed_text(self) -> str:
        """``+0.012 [-0.003, +0.027]``, with ``*`` where the interval excludes zero (a table
        cell of a difference)."""
        star = "*" if self.excludes_zero() else ""
        return f"{self.mean:+.3f} [{self.low:+.3f}, {self.high:+.3f}]{star}"


def bootstrap_means(
    values: np.ndarray, clusters: np.ndarray, replicates: int = REPLICATES, seed: int = 0
) -> np.ndarray:
    """(R,) means of ``values`` over ``replicates`` resamples of whole clusters.

    Args:
        values: (S,) per-sample values, e.g. FDE in metres or a paired difference.
        clusters: (S,) cluster (time step) of every sample, any integers.
        replicates: R, the number of resamples.
        seed: seed of the resampling; equal seeds and clusters give equal resamples, so two
            calls on the same samples are paired.

    Returns:
        (R,) the sample-weighted mean of each resample (a resample draws as many clusters as
        there are, with replacement).
    """
    if len(values) == 0:
        raise ValueError("no values to bootstrap")
    _, cluster = np.unique(clusters, return_inverse=True)
    cluster = cluster.reshape(-1)
    num_clusters = int(cluster.max()) + 1
    sums = np.bincount(cluster, weights=values, minlength=num_clusters)  # (C,)
    sizes = np.bincount(cluster, minlength=num_clusters).astype(np.float64)  # (C,)
    rng = np.random.default_rng(seed)
    draws = rng.multinomial(num_clusters, np.full(num_clusters, 1.0 / num_clusters), replicates)
    return (draws @ sums) / (draws @ sizes)  # (R,)


def interval(mean: float, replicate_means: np.ndarray, level: float = LEVEL) -> Interval:
    """The percentile interval of ``replicate_means`` around the observed ``mean``."""
    tail = 100.0 * (1.0 - level) / 2.0
    low, high = np.percentile(replicate_means, [tail, 100.0 - tail])
    return Interval(float(mean), float(low), float(high))


def mean_interval(
    values: np.ndarray, clusters: np.ndarray, replicates: int = REPLICATES, seed: int = 0
) -> Interval:
    """The mean of (S,) ``values`` with its cluster-bootstrap interval."""
    return interval(float(values.mean()), bootstrap_means(values, clusters, replicates, seed))


def split_average_interval(
    per_split: Sequence[tuple[np.ndarray, np.ndarray]], replicates: int = REPLICATES, seed: int = 0
) -> Interval:
    """The unweighted mean of split means (the papers' AVG) with its interval: each split is
    resampled on its own time steps and the replicate means are averaged across splits.

    Args:
        per_split: one (values (S_i,), clusters (S_i,)) pair per split.
    """
    means = [float(v.mean()) for v, _ in per_split]
    replicate = np.mean(
        [bootstrap_means(v, c, replicates, seed + i) for i, (v, c) in enumerate(per_split)], axis=0
    )
    return interval(float(np.mean(means)), replicate)


def column_intervals(
    per_split: Sequence[tuple[np.ndarray, np.ndarray]], replicates: int = REPLICATES, seed: int = 0
) -> list[Interval]:
    """Each column's mean of (S, D) values (a metric per forecast step) with its interval, the
    same resamples for every column: one split's cluster bootstrap (as :func:`mean_interval`),
    or the average of several splits' (as :func:`split_average_interval`).

    Args:
        per_split: one (values (S_i, D), clusters (S_i,)) pair per split.
    """
    means, replicate = [], []
    for i, (values, clusters) in enumerate(per_split):
        if len(values) == 0:
            raise ValueError("no values to bootstrap")
        _, cluster = np.unique(clusters, return_inverse=True)
        cluster = cluster.reshape(-1)
        num_clusters = int(cluster.max()) + 1
        sums = np.zeros((num_clusters, values.shape[1]))
        np.add.at(sums, cluster, values)  # (C, D)
        sizes = np.bincount(cluster, minlength=num_clusters).astype(np.float64)  # (C,)
        rng = np.random.default_rng(seed + i)
        draws = rng.multinomial(num_clusters, np.full(num_clusters, 1.0 / num_clusters), replicates)
        replicate.append((draws @ sums) / (draws @ sizes)[:, None])  # (R, D)
        means.append(values.mean(axis=0))
    mean, replicates_mean = np.mean(means, axis=0), np.mean(replicate, axis=0)  # (D,), (R, D)
    return [interval(float(m), replicates_mean[:, d]) for d, m in enumerate(mean)]


def seed_spread(values: Sequence[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof 1) over seed runs; sd is NaN for one run."""
    array = np.asarray(values, dtype=np.float64)
    sd = float(array.std(ddof=1)) if len(array) > 1 else float("nan")
    return float(array.mean()), sd
