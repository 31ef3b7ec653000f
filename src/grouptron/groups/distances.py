"""Hausdorff distances between trajectories, for all pairs of nodes at once.

Pure NumPy on ``...`` leading dimensions: ``(..., N, T, 2)`` trajectories with an ``(..., N, T)``
mask give ``(..., N, N)`` distances from one ``(..., N, N, T, T)`` array of point distances.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

DistanceKind = Literal["hausdorff", "modified"]
DISTANCE_KINDS: tuple[DistanceKind, ...] = ("hausdorff", "modified")


def point_to_trajectory(traj: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Distance from every point of trajectory i to the nearest point of trajectory j.

    Args:
        traj: (..., N, T, 2) positions.
        mask: (..., N, T) True where observed.

    Returns:
        (..., N, N, T) ``d[i, j, a] = min_b |traj_i[a] - traj_j[b]|`` over observed b; NaN where
        point a of i is not observed (inf if j has no observed point).
    """
    x, y = traj[..., 0], traj[..., 1]  # (..., N, T) each
    dx = x[..., :, None, :, None] - x[..., None, :, None, :]  # (..., N, N, T, T)
    dy = y[..., :, None, :, None] - y[..., None, :, None, :]
    squared = dx * dx + dy * dy
    squared = np.where(mask[..., None, :, None, :], squared, np.inf)  # only observed points of j
    nearest = np.sqrt(squared.min(axis=-1))  # (..., N, N, T); sqrt after the min is cheaper
    return np.where(mask[..., :, None, :], nearest, np.nan)


def directed_hausdorff(
    traj: np.ndarray, mask: np.ndarray, kind: DistanceKind = "hausdorff", quantile: float = 0.9
) -> np.ndarray:
    """(..., N, N) directed distance from trajectory i to trajectory j.

    ``hausdorff``: the largest point-to-trajectory distance. ``modified`` (Atev et al., 2010):
    its ``quantile``, which ignores a few outlying points.
    """
    nearest = point_to_trajectory(traj, mask)
    if kind == "hausdorff":
        return np.nanmax(nearest, axis=-1)
    if kind == "modified":
        return np.nanquantile(nearest, quantile, axis=-1)
    raise ValueError(f"unknown distance {kind!r}; choose from {DISTANCE_KINDS}")


def pairwise_distances(
    traj: np.ndarray, mask: np.ndarray, kind: DistanceKind = "hausdorff", quantile: float = 0.9
) -> np.ndarray:
    """(..., N, N) symmetric distances ``max(h(i, j), h(j, i))``; zero on the diagonal.

    Args:
        traj: (..., N, T, 2) positions in metres, any common frame.
        mask: (..., N, T) True where observed; every node needs at least one observed point.
        kind: ``"hausdorff"`` or ``"modified"``.
        quantile: the modified distance's quantile.
    """
    directed = directed_hausdorff(traj, mask, kind, quantile)
    symmetric = np.maximum(directed, np.swapaxes(directed, -1, -2))
    n = traj.shape[-3]
    return np.where(np.eye(n, dtype=bool), 0.0, symmetric)
