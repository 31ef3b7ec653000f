"""Hausdorff distances between trajectories, for all pairs of nodes at once.

Pure NumPy on ``...`` leading dimensions: ``(..., N, T, 2)`` trajectories with an ``(..., N, T)``
mask give ``(..., N, N)`` distances from one ``(..., N, N, T, T)`` array of point distances.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from grouptron import constants

DistanceKind = Literal["hausdorff", "modified"]
DISTANCE_KINDS: tuple[DistanceKind, ...] = constants.DISTANCE_KINDS


def _nearest_distances(traj: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(..., N, T, N) ``d[j, a, i] = min_b |traj_i[a] - traj_j[b]|`` over observed b.

    The layout keeps both reductions (over b here, over a by the caller) on outer axes, where
    NumPy reduces whole contiguous rows at a time; reducing a length-T inner axis is several
    times slower.
    """
    x = np.swapaxes(traj[..., 0], -1, -2)  # (..., T, N): x[a, i]
    y = np.swapaxes(traj[..., 1], -1, -2)
    # (..., j, b, a, i) differences between point b of j and point a of i.
    dx = x[..., None, None, :, :] - np.swapaxes(x, -1, -2)[..., :, :, None, None]
    dy = y[..., None, None, :, :] - np.swapaxes(y, -1, -2)[..., :, :, None, None]
    squared = dx * dx
    squared += dy * dy
    unobserved = np.broadcast_to(~mask[..., :, :, None, None], squared.shape)
    squared[unobserved] = np.inf  # only observed points b of j count
    return np.sqrt(squared.min(axis=-3))  # sqrt after the min is cheaper


def point_to_trajectory(traj: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Distance from every point of trajectory i to the nearest point of trajectory j.

    Args:
        traj: (..., N, T, 2) positions.
        mask: (..., N, T) True where observed.

    Returns:
        (..., N, N, T) ``d[i, j, a] = min_b |traj_i[a] - traj_j[b]|`` over observed b; NaN where
        point a of i is not observed (inf if j has no observed point).
    """
    nearest = np.moveaxis(_nearest_distances(traj, mask), (-3, -2, -1), (-2, -1, -3))
    return np.where(mask[..., :, None, :], nearest, np.nan)


def directed_hausdorff(
    traj: np.ndarray, mask: np.ndarray, kind: DistanceKind = "hausdorff", quantile: float = 0.9
) -> np.ndarray:
    """(..., N, N) directed distance from trajectory i to trajectory j.

    ``hausdorff``: the largest point-to-trajectory distance. ``modified`` (Atev et al., 2010):
    its ``quantile``, which ignores a few outlying points.
    """
    if kind == "hausdorff":
        nearest = _nearest_distances(traj, mask)  # (..., j, a, i)
        observed = np.swapaxes(mask, -1, -2)[..., None, :, :]  # (..., 1, a, i)
        farthest = np.where(observed, nearest, -np.inf).max(axis=-2)  # (..., j, i)
        return np.swapaxes(farthest, -1, -2)
    if kind == "modified":
        return np.nanquantile(point_to_trajectory(traj, mask), quantile, axis=-1)
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
    if kind == "hausdorff" and traj.ndim == 3 and mask.any(axis=1).all():
        return _hausdorff_one_set(traj, mask)
    directed = directed_hausdorff(traj, mask, kind, quantile)
    symmetric = np.maximum(directed, np.swapaxes(directed, -1, -2))
    n = traj.shape[-3]
    return np.where(np.eye(n, dtype=bool), 0.0, symmetric)


def _hausdorff_one_set(traj: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """:func:`pairwise_distances` of one (N, T, 2) set, several times faster for a whole scene:
    the squared distances of all N T points in one matrix (unobserved points moved out of
    reach), then minima and maxima over whole blocks of it; equal to the general path (the
    same squared distances, and sqrt is monotone)."""
    N, T = mask.shape
    reach = 4.0 * float(np.abs(traj[mask]).max(initial=0.0)) + 1.0  # beyond every real pair
    points = np.where(mask[..., None], traj, reach).reshape(N * T, 2)
    squared = cdist(points, points, "sqeuclidean").reshape(N, T, N * T)  # (j, b, (i, a))
    nearest = squared.min(axis=1)  # (j, (i, a)): the nearest point b of j to point a of i
    nearest[:, ~mask.reshape(-1)] = -np.inf  # only observed points a of i count
    farthest = nearest.reshape(N, N, T).max(axis=2)  # (j, i)
    symmetric = np.sqrt(np.maximum(farthest, farthest.T))
    np.fill_diagonal(symmetric, 0.0)
    return symmetric


def mean_velocities(traj: np.ndarray, mask: np.ndarray, dt_s: float) -> np.ndarray:
    """(..., N, 2) mean velocity of each trajectory over its observed points: (last - first) /
    elapsed time; 0 for a single point. ``traj`` (..., N, T, 2), ``mask`` (..., N, T)."""
    T = mask.shape[-1]
    step = np.arange(T)
    first = np.where(mask, step, T).min(axis=-1)  # (..., N)
    last = np.where(mask, step, -1).max(axis=-1)
    take = np.minimum(np.stack([first, last], -1), T - 1)  # (..., N, 2)
    ends = np.take_along_axis(traj, take[..., None], axis=-2)  # (..., N, 2, 2)
    elapsed = np.maximum(last - first, 1)[..., None] * dt_s
    return (ends[..., 1, :] - ends[..., 0, :]) / elapsed


def group_distances(
    traj: np.ndarray,
    mask: np.ndarray,
    *,
    kind: DistanceKind,
    quantile: float,
    velocity_weight_s: float,
    dt_s: float,
) -> np.ndarray:
    """(..., N, N) distances the grouping clusters on: :func:`pairwise_distances`, and with
    ``velocity_weight_s`` > 0 at least that many seconds times the difference of the mean
    velocities (walking together means walking alike)."""
    distances = pairwise_distances(traj, mask, kind, quantile)
    if velocity_weight_s <= 0:
        return distances
    velocity = mean_velocities(traj, mask, dt_s)  # (..., N, 2)
    apart = np.linalg.norm(velocity[..., :, None, :] - velocity[..., None, :, :], axis=-1)
    return np.maximum(distances, velocity_weight_s * apart)


def near_pairs(
    traj: np.ndarray,
    mask: np.ndarray,
    pos_now: np.ndarray,
    within_m: float,
    alike: tuple[np.ndarray, float] | None = None,
) -> np.ndarray:
    """(P, 2) pairs i < j of the N trajectories that :func:`pairwise_distances` can put
    within ``within_m`` of each other, found with one k-d tree query on their (N, 2)
    positions now instead of all N^2 pairs, then screened pair by pair (both in order).

    Why: the distance from i to j is at least the distance from i now to the nearest point of
    j (i now is one of i's points), which is at least the distance between them now less how
    far j's window reaches from j now (R_j). So a pair farther apart now than ``within_m``
    plus the largest reach R of anyone is never within ``within_m`` (the tree), and neither is
    one where i now or j now is farther than ``within_m`` from every point of the other (the
    screen). With ``alike`` ((N, 2) mean velocities, the largest difference in m/s) pairs
    that differ more are dropped before the screen (a rule that weighs velocity differences
    never links them, and the screen is the costly part).
    """
    offsets = np.where(mask[..., None], traj - pos_now[:, None, :], 0.0)
    reach = float(np.sqrt((offsets**2).sum(-1)).max(initial=0.0))
    radius = (within_m + reach) * 1.0001 + 1e-9  # the tree screens with a margin
    pairs = cKDTree(pos_now).query_pairs(radius, output_type="ndarray").astype(np.int64)
    if alike is not None:
        velocity, most_mps = alike
        apart = velocity[pairs[:, 0]] - velocity[pairs[:, 1]]  # (P, 2)
        limit_mps = most_mps * (1 + 1e-9) + 1e-12  # rounding: keep ties
        pairs = pairs[(apart * apart).sum(axis=1) <= limit_mps * limit_mps]
    if not len(pairs):
        return np.zeros((0, 2), dtype=np.int64)
    points = np.where(mask[..., None], traj, np.inf)  # (N, T, 2) unobserved: never nearest
    i, j = pairs[:, 0], pairs[:, 1]  # i < j (the tree's order)
    bound_squared = np.maximum(
        _nearest_squared(pos_now[i], points[j]), _nearest_squared(pos_now[j], points[i])
    )  # (P,) at most each pair's squared distance
    limit = within_m * (1 + 1e-9) + 1e-12  # rounding: keep ties
    kept: np.ndarray = pairs[bound_squared <= limit * limit]
    return kept


def _nearest_squared(point: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(P,) squared distance from each (P, 2) point to the nearest of its (P, T, 2) points."""
    dx = points[..., 0] - point[:, 0, None]  # (P, T)
    dy = points[..., 1] - point[:, 1, None]
    squared: np.ndarray = (dx * dx + dy * dy).min(axis=1)
    return squared


def pair_hausdorff(traj: np.ndarray, mask: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """(P,) :func:`pairwise_distances` (``hausdorff``) of the (P, 2) ``pairs`` only, computed
    as its one-set path computes them: squared point distances with unobserved points moved
    out of reach, the nearest over b and the farthest over observed a, the larger direction,
    then the square root."""
    reach = 4.0 * float(np.abs(traj[mask]).max(initial=0.0)) + 1.0  # beyond every real pair
    points = np.where(mask[..., None], traj, reach)  # (N, T, 2)
    a, b = points[pairs[:, 0]], points[pairs[:, 1]]  # (P, T, 2)
    dx = a[:, :, None, 0] - b[:, None, :, 0]  # (P, Ta, Tb)
    dy = a[:, :, None, 1] - b[:, None, :, 1]
    squared = dx * dx
    squared += dy * dy
    to_j = np.where(mask[pairs[:, 0]], squared.min(axis=2), -np.inf)  # (P, Ta)
    to_i = np.where(mask[pairs[:, 1]], squared.min(axis=1), -np.inf)  # (P, Tb)
    distance: np.ndarray = np.sqrt(np.maximum(to_j.max(axis=1), to_i.max(axis=1)))
    return distance


def sparse_pair_distances(
    traj: np.ndarray,
    mask: np.ndarray,
    pos_now: np.ndarray,
    *,
    within_m: float,
    velocity_weight_s: float,
    dt_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(P, 2) the pairs :func:`near_pairs` finds (those apart by more than ``within_m`` /
    ``velocity_weight_s`` in mean velocity dropped first) and (P,) their
    :func:`group_distances` (``hausdorff``): every pair within ``within_m`` and some beyond,
    without the N^2 T^2 work of all pairs (a station's 300 people). What a clustering at
    ``within_m`` with single linkage and no size cap decides (its connected pieces) is the
    same as with all pairs; its merges beyond ``within_m`` are not."""
    velocity = mean_velocities(traj, mask, dt_s) if velocity_weight_s > 0 else None
    alike = None if velocity is None else (velocity, within_m / velocity_weight_s)
    pairs = near_pairs(traj, mask, pos_now, within_m, alike)
    distance = pair_hausdorff(traj, mask, pairs)
    if velocity is not None and len(pairs):
        apart = np.linalg.norm(velocity[pairs[:, 0]] - velocity[pairs[:, 1]], axis=-1)
        distance = np.maximum(distance, velocity_weight_s * apart)
    return pairs, distance


def pair_matrix(n: int, pairs: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """(n, n) symmetric ``distance`` of the (P, 2) ``pairs``, infinity elsewhere, 0 on the
    diagonal."""
    out = np.full((n, n), np.inf)
    out[pairs[:, 0], pairs[:, 1]] = distance
    out[pairs[:, 1], pairs[:, 0]] = distance
    np.fill_diagonal(out, 0.0)
    return out
