"""Agglomerative clustering of nodes into C(N) = (N + 1) // 2 groups (the Grouptron rule)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.cluster.hierarchy import linkage
from scipy.spatial.distance import squareform

Linkage = Literal["single", "average", "complete"]
LINKAGES: tuple[Linkage, ...] = ("single", "average", "complete")


def cluster_count(num_nodes: int) -> int:
    """C(N) = (N + 1) // 2: the paper's (N + 1) / 2 groups, rounded down."""
    if num_nodes < 1:
        raise ValueError("need at least one node")
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
    """Group labels of N nodes from their (N, N) distance matrix.

    SciPy's hierarchical clustering is deterministic for a given node order, so ties are broken
    the same way on every run.

    Args:
        distances: (N, N) symmetric, zero diagonal.
        method: the linkage.
        num_groups: how many groups (default ``cluster_count(N)``).

    Returns:
        (N,) labels in ``0..num_groups-1``, numbered by first member.
    """
    n = len(distances)
    count = cluster_count(n) if num_groups is None else num_groups
    if method not in LINKAGES:
        raise ValueError(f"unknown linkage {method!r}; choose from {LINKAGES}")
    if count >= n:
        return np.arange(n)
    if count <= 1:
        return np.zeros(n, dtype=np.int64)
    tree = linkage(squareform(distances, checks=False), method=method)
    return canonical_labels(cut_merge_tree(tree, n, count))


def cut_merge_tree(tree: np.ndarray, num_leaves: int, num_groups: int) -> np.ndarray:
    """The partition after the first ``num_leaves - num_groups`` merges of a SciPy linkage.

    Equivalent to ``scipy.cluster.hierarchy.cut_tree(tree, n_clusters=num_groups)`` (the merge
    heights of single, average and complete linkage never decrease), without building the tree
    object, which costs milliseconds per call.

    Args:
        tree: (num_leaves - 1, 4) linkage matrix; row k merges clusters ``tree[k, 0]`` and
            ``tree[k, 1]`` into cluster ``num_leaves + k``.

    Returns:
        (num_leaves,) labels.
    """
    members: dict[int, list[int]] = {leaf: [leaf] for leaf in range(num_leaves)}
    for k, (a, b) in enumerate(tree[: num_leaves - num_groups, :2].astype(np.int64)):
        members[num_leaves + k] = members.pop(int(a)) + members.pop(int(b))
    labels = np.empty(num_leaves, dtype=np.int64)
    for group, leaves in enumerate(members.values()):
        labels[leaves] = group
    return labels
