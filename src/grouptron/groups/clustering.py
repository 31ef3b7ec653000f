"""Agglomerative clustering of nodes into C(N) = (N + 1) // 2 groups (the Grouptron rule)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.cluster.hierarchy import linkage
from scipy.spatial.distance import squareform

from grouptron import constants

Linkage = Literal["single", "average", "complete"]
LINKAGES: tuple[Linkage, ...] = constants.LINKAGES
SCIPY_FROM_NODES = 24
"""A single set this large, without tied distances, is clustered by SciPy's linkage (same
partition, a test checks): one NumPy pass per merge costs more there (a whole crowd)."""


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
    distances: np.ndarray,
    method: Linkage = "average",
    num_groups: int | None = None,
    *,
    max_distance: float | None = None,
    max_size: int | None = None,
) -> np.ndarray:
    """Group labels of N nodes from their (N, N) distance matrix (symmetric, zero diagonal):
    :func:`agglomerative_groups_batched` on a stack of one. Deterministic, also with ties.

    Returns:
        (N,) labels in ``0..num_groups-1`` (default ``cluster_count(N)``; with
        ``max_distance``, as many as merging clusters at most that far apart leaves),
        numbered by first member.
    """
    n = len(distances)
    if n < 1:
        raise ValueError("need at least one node")
    if n >= SCIPY_FROM_NODES and method in LINKAGES and max_size is None:
        pairs = squareform(distances, checks=False)  # (n (n-1) / 2,) condensed
        if len(np.unique(pairs)) == len(pairs):  # no ties: the merge order is unique
            merges = linkage(pairs, method)  # heights ascending (these linkages are monotone)
            if max_distance is not None:
                count = n - int(np.searchsorted(merges[:, 2], max_distance, side="right"))
            else:
                count = cluster_count(n) if num_groups is None else num_groups
            return _cut_dendrogram(merges, n, min(max(count, 1), n))
    return agglomerative_groups_batched(
        distances[None], method, num_groups, max_distance=max_distance, max_size=max_size
    )[0]


def _cut_dendrogram(merges: np.ndarray, n: int, count: int) -> np.ndarray:
    """(n,) labels after the first ``n - count`` merges of a SciPy linkage matrix (a loop over
    merges, as the vectorised algorithm's), numbered by first member."""
    members: dict[int, list[int]] = {i: [i] for i in range(n)}
    for m, (a, b) in enumerate(merges[: n - count, :2].astype(np.int64)):
        members[n + m] = members.pop(int(a)) + members.pop(int(b))
    labels = np.empty(n, dtype=np.int64)
    for cluster, nodes in enumerate(members.values()):
        labels[nodes] = cluster
    return canonical_labels(labels)


def agglomerative_groups_batched(
    distances: np.ndarray,
    method: Linkage = "average",
    num_groups: int | None = None,
    *,
    num_nodes: np.ndarray | None = None,
    max_distance: float | None = None,
    max_size: int | None = None,
) -> np.ndarray:
    """Group labels of S independent sets of N nodes, merged in lockstep.

    The textbook algorithm vectorised over the stack: each round merges, in every matrix, the
    closest pair of live clusters and updates the merged cluster's distances by the linkage's
    Lance-Williams rule. Without tied distances the partition equals SciPy's (a test checks);
    with ties the lower pair index wins. One NumPy pass per merge, not one SciPy call per set.

    Args:
        distances: (S, N, N) symmetric, zero diagonals.
        method: the linkage.
        num_groups: how many groups (default ``cluster_count(N)``).
        num_nodes: (S,) real nodes of every set when sets of different sizes are padded to N:
            set s has nodes ``0..num_nodes[s]-1`` (its padding rows and columns must be inf)
            and is merged into ``cluster_count(num_nodes[s])`` groups, exactly as alone.
        max_distance: instead of a group count, merge while the two closest clusters are at
            most this far apart (the dendrogram cut at a height; these linkages are monotone,
            so a set stops for good at its first closest pair beyond it).
        max_size: with ``max_distance``, skip merges into clusters above this size (the
            closest pair that fits merges instead): a chain of close people is cut in pieces.

    Returns:
        (S, N) labels numbered by first member (padding nodes after the real ones, alone).
    """
    if method not in LINKAGES:
        raise ValueError(f"unknown linkage {method!r}; choose from {LINKAGES}")
    if max_size is not None and max_distance is None:
        raise ValueError("max_size limits a cut at max_distance; give both")
    (S, n), below = distances.shape[:2], np.tril(np.ones(distances.shape[1:], dtype=bool))
    merges = _merges_per_set(S, n, num_groups, num_nodes, until_height=max_distance is not None)
    d = distances.astype(np.float64, copy=True)
    d[:, np.arange(n), np.arange(n)] = np.inf
    size = np.ones((S, n))
    owner = np.broadcast_to(np.arange(n), (S, n)).copy()  # cluster of each node = its lowest
    stopped = np.zeros(S, dtype=bool)  # beyond max_distance for good
    for merge in range(int(merges.max(initial=0))):  # each merge vectorised over the sets
        rows = np.flatnonzero((merges > merge) & ~stopped)  # the sets still merging
        if not len(rows):  # the rest stopped at their height, the others are done
            break
        live = d if len(rows) == S else d[rows]
        flat, height = _closest_pairs(live, below, size[rows], max_size)
        if max_distance is not None:
            close = height <= max_distance
            stopped[rows[~close]] = True
            rows, flat = rows[close], flat[close]
            if not len(rows):
                break
        _merge(d, size, owner, rows, flat, method=method)
    # Number the clusters 0, 1, ... by their lowest node, i.e. by first member.
    is_lowest = owner == np.arange(n)
    number = np.cumsum(is_lowest, axis=1) - 1  # (S, n)
    return np.take_along_axis(number, owner, axis=1)


def _closest_pairs(
    live: np.ndarray, below: np.ndarray, size: np.ndarray, max_size: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """(R,) flat index and distance of every set's closest pair of (R, n, n) ``live``, among
    the pairs (not ``below``: the diagonal and lower triangle) whose merged cluster would have
    at most ``max_size`` members ((R, n) ``size``); inf where no pair is left."""
    excluded = below
    if max_size is not None:
        excluded = below | (size[:, :, None] + size[:, None, :] > max_size)
    candidates = np.where(excluded, np.inf, live).reshape(len(live), -1)
    flat = candidates.argmin(axis=1)
    return flat, candidates[np.arange(len(live)), flat]


def _merges_per_set(
    S: int, n: int, num_groups: int | None, num_nodes: np.ndarray | None, *, until_height: bool
) -> np.ndarray:
    """(S,) merges each set needs: down to ``num_groups`` or C(N) of its real nodes; or, cut
    at a height (``until_height``), at most down to one group (the height stops it)."""
    if until_height:
        if num_groups is not None:
            raise ValueError("give num_groups or max_distance, not both")
        real = np.full(S, n) if num_nodes is None else num_nodes
        return np.maximum(real - 1, 0)
    if num_nodes is None:
        count = cluster_count(n) if num_groups is None else num_groups
        return np.full(S, n - min(max(count, 1), n))
    if num_groups is not None:
        raise ValueError("give num_groups or num_nodes, not both")
    return num_nodes - cluster_counts(num_nodes)  # padding is never closest (inf)


def _merge(
    d: np.ndarray,
    size: np.ndarray,
    owner: np.ndarray,
    rows: np.ndarray,
    flat: np.ndarray,
    *,
    method: Linkage,
) -> None:
    """Merge, in sets ``rows``, the pair at flat index ``flat`` of (S, n, n) ``d`` (in place:
    the distances, (S, n) cluster sizes and owners)."""
    n = d.shape[-1]
    keep, gone = flat // n, flat % n  # (R,) keep < gone
    a, b = d[rows, keep], d[rows, gone]  # (R, n) distances of the two clusters
    merged = _lance_williams(
        method, a, b, size_a=size[rows, keep, None], size_b=size[rows, gone, None]
    )
    merged[np.arange(len(rows)), keep] = np.inf
    merged[np.arange(len(rows)), gone] = np.inf
    d[rows, keep] = merged
    d[rows, :, keep] = merged
    d[rows, gone] = np.inf
    d[rows, :, gone] = np.inf
    size[rows, keep] += size[rows, gone]
    owner[rows] = np.where(owner[rows] == gone[:, None], keep[:, None], owner[rows])


def _lance_williams(
    method: Linkage, a: np.ndarray, b: np.ndarray, *, size_a: np.ndarray, size_b: np.ndarray
) -> np.ndarray:
    """Distances of a merged cluster from those of its two parts, (R, n) each (sizes (R, 1))."""
    if method == "single":
        return np.minimum(a, b)
    if method == "complete":
        return np.maximum(a, b)
    return (size_a * a + size_b * b) / (size_a + size_b)


def linked_pieces(n: int, linked: np.ndarray) -> np.ndarray:
    """(n,) a label per connected piece of n people joined by (L, 2) ``linked`` pairs (the
    smallest member's index): roots hooked under smaller roots, then every label followed to
    its root, until every pair agrees. A few passes of O(L + n) each, even along a chain
    through a crowd; SciPy's ``connected_components`` would first convert and check a sparse
    matrix, which costs more than that at a live step's hundred links."""
    label = np.arange(n)
    i, j = linked[:, 0], linked[:, 1]
    while True:
        label_i, label_j = label[i], label[j]  # roots: every label is one after a pass
        if np.array_equal(label_i, label_j):
            return label
        # The larger root of each disagreeing pair under the smaller: labels never rise, so
        # no cycle forms.
        np.minimum.at(label, np.maximum(label_i, label_j), np.minimum(label_i, label_j))
        while True:  # compress
            up = label[label]
            if np.array_equal(up, label):
                break
            label = up
