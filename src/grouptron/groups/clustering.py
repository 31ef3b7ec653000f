"""Agglomerative clustering of nodes into C(N) = (N + 1) // 2 groups (the Grouptron rule)."""

from __future__ import annotations

from typing import Literal

import numpy as np

Linkage = Literal["single", "average", "complete"]
LINKAGES: tuple[Linkage, ...] = ("single", "average", "complete")


def cluster_count(num_nodes: int) -> int:
    """C(N) = (N + 1) // 2: the paper's (N + 1) / 2 groups, rounded down."""
    if num_nodes < 1:
        raise ValueError("need at least one node")
    return int(cluster_counts(np.asarray([num_nodes]))[0])


def cluster_counts(num_nodes: np.ndarray) -> np.ndarray:
    """(S,) node counts -> (S,) C(N), the one place the paper's rule is written."""
    return (num_nodes + 1) // 2


def canonical_labels(labels: np.ndarray) -> np.ndarray:
    """Renumber groups 0, 1, ... in order of their first member, so equal partitions compare
    equal whatever the clustering library called the groups."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.argsort(np.argsort(first))
    return rank[inverse.reshape(-1)]


def agglomerative_groups(
    distances: np.ndarray, method: Linkage = "average", num_groups: int | None = None
) -> np.ndarray:
    """Group labels of N nodes from their (N, N) distance matrix (symmetric, zero diagonal):
    :func:`agglomerative_groups_batched` on a stack of one. Deterministic, also with ties.

    Returns:
        (N,) labels in ``0..num_groups-1`` (default ``cluster_count(N)``), numbered by first
        member.
    """
    if len(distances) < 1:
        raise ValueError("need at least one node")
    return agglomerative_groups_batched(distances[None], method, num_groups)[0]


def agglomerative_groups_batched(
    distances: np.ndarray, method: Linkage = "average", num_groups: int | None = None
) -> np.ndarray:
    """Group labels of S independent sets of N nodes, merged in lockstep.

    The textbook algorithm vectorised over the stack: each round merges, in every matrix, the
    closest pair of live clusters and updates the merged cluster's distances by the
    Lance-Williams rule of the linkage (min, size-weighted mean, max). Without tied distances
    the partition equals SciPy's (a test checks); with ties the lower pair index wins.
    One NumPy pass per merge replaces one SciPy call per matrix, which dominates when
    thousands of small matrices (one per sample) are clustered.

    Args:
        distances: (S, N, N) symmetric, zero diagonals.
        method: the linkage.
        num_groups: how many groups (default ``cluster_count(N)``).

    Returns:
        (S, N) labels in ``0..num_groups-1``, numbered by first member.
    """
    if method not in LINKAGES:
        raise ValueError(f"unknown linkage {method!r}; choose from {LINKAGES}")
    S, n = distances.shape[:2]
    count = cluster_count(n) if num_groups is None else num_groups
    if count >= n or S == 0:
        return np.broadcast_to(np.arange(n), (S, n)).copy()
    d = distances.astype(np.float64, copy=True)
    below = np.tril(np.ones((n, n), dtype=bool))  # diagonal and lower triangle: not pairs
    d[:, np.arange(n), np.arange(n)] = np.inf
    size = np.ones((S, n))
    owner = np.broadcast_to(np.arange(n), (S, n)).copy()  # cluster of each node = its lowest
    rows = np.arange(S)
    for _ in range(n - max(count, 1)):  # merges; each is vectorised over the S matrices
        flat = np.where(below, np.inf, d).reshape(S, n * n).argmin(axis=1)
        keep, gone = flat // n, flat % n  # (S,) keep < gone
        a, b = d[rows, keep], d[rows, gone]  # (S, n) distances of the two clusters
        if method == "single":
            merged = np.minimum(a, b)
        elif method == "complete":
            merged = np.maximum(a, b)
        else:
            size_a, size_b = size[rows, keep, None], size[rows, gone, None]
            merged = (size_a * a + size_b * b) / (size_a + size_b)
        merged[rows, keep] = np.inf
        merged[rows, gone] = np.inf
        d[rows, keep] = merged
        d[rows, :, keep] = merged
        d[rows, gone] = np.inf
        d[rows, :, gone] = np.inf
        size[rows, keep] += size[rows, gone]
        owner = np.where(owner == gone[:, None], keep[:, None], owner)
    # Number the clusters 0, 1, ... by their lowest node, i.e. by first member.
    is_lowest = owner == np.arange(n)
    number = np.cumsum(is_lowest, axis=1) - 1  # (S, n)
    return np.take_along_axis(number, owner, axis=1)
