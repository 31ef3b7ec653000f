"""Pure geometry: finite-difference derivatives along tracks and planar rotations.

No state, no device choice, no mutation. Functions accept any leading dimensions (``...``).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

DerivativeScheme = Literal["central", "backward"]
DERIVATIVE_SCHEMES: tuple[DerivativeScheme, ...] = ("central", "backward")
BackwardStart = Literal["zero", "next"]
"""How ``backward`` derivatives begin a track: ``zero`` (strictly causal, the default) or
``next`` (copy the second row's value, as the reference does; it reads the next position)."""


def track_derivative(
    values: np.ndarray,
    track: np.ndarray,
    dt_s: float,
    scheme: DerivativeScheme,
    backward_start: BackwardStart = "zero",
) -> np.ndarray:
    """Time derivative of per-row values along gap-free tracks.

    Rows must be sorted by (track, step) with consecutive steps inside a track.

    ``central`` follows ``np.gradient``: ``(v[t+1] - v[t-1]) / 2dt`` inside a track, one-sided
    first differences at both ends (it uses t+1, so it is not causal). ``backward`` is
    ``(v[t] - v[t-1]) / dt``; at a track's first row, where no earlier value exists, it is 0
    (``backward_start="zero"``: strictly causal) or the second row's value (``"next"``: the
    reference's rule, which reads the next position). A single-row track gets zeros.

    Args:
        values: (R, D) values, e.g. positions.
        track: (R,) track index of every row.
        dt_s: seconds per step.
        scheme: ``"central"`` or ``"backward"``.

    Returns:
        (R, D) derivatives.
    """
    if scheme not in DERIVATIVE_SCHEMES:
        raise ValueError(f"unknown derivative scheme {scheme!r}; choose from {DERIVATIVE_SCHEMES}")
    same_as_prev = np.zeros(len(track), dtype=bool)
    same_as_prev[1:] = track[1:] == track[:-1]
    same_as_next = np.zeros(len(track), dtype=bool)
    same_as_next[:-1] = same_as_prev[1:]
    prev = np.roll(values, 1, axis=0)
    nxt = np.roll(values, -1, axis=0)
    forward_diff = (nxt - values) / dt_s
    backward_diff = (values - prev) / dt_s
    has_prev, has_next = same_as_prev[:, None], same_as_next[:, None]
    if scheme == "central":
        interior = (nxt - prev) / (2.0 * dt_s)
        edge = np.where(has_next, forward_diff, np.where(has_prev, backward_diff, 0.0))
        return np.where(has_prev & has_next, interior, edge)
    first = np.where(has_next, forward_diff, 0.0) if backward_start == "next" else 0.0
    return np.where(has_prev, backward_diff, first)


def track_states(
    pos_m: np.ndarray,
    track: np.ndarray,
    dt_s: float,
    scheme: DerivativeScheme,
    backward_start: BackwardStart = "zero",
) -> np.ndarray:
    """Position, velocity and acceleration of every row: (R, 2) positions -> (R, 6) states.

    Under strictly causal ``backward`` derivatives a row's acceleration needs two earlier rows
    of its track; it is 0 on a track's first two rows, so every state at step t depends only on
    positions at or before t. (``backward_start="next"`` gives the reference's values.)
    """
    vel = track_derivative(pos_m, track, dt_s, scheme, backward_start)
    acc = track_derivative(vel, track, dt_s, scheme, backward_start)
    if scheme == "backward" and backward_start == "zero":
        has_two_before = np.zeros(len(track), dtype=bool)
        has_two_before[2:] = track[2:] == track[:-2]  # rows sorted, steps consecutive
        acc = np.where(has_two_before[:, None], acc, 0.0)
    return np.concatenate([pos_m, vel, acc], axis=-1)


def rotation_matrix(angle_rad: np.ndarray) -> np.ndarray:
    """(...,) angles -> (..., 2, 2) counter-clockwise rotation matrices."""
    cos, sin = np.cos(angle_rad), np.sin(angle_rad)
    return np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)


def rotate_rows(values: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rotate every (x, y) pair of row ``r`` of ``values`` by ``rotation[r]``.

    Args:
        values: (R, ..., 2P) e.g. (S, T, 6) histories of S samples.
        rotation: (R, 2, 2) one rotation per row.

    Returns:
        (R, ..., 2P) rotated values, same dtype.
    """
    per_row = rotation.reshape(len(values), *([1] * (values.ndim - 2)), 2, 2)
    return rotate_xy_pairs(values, per_row).astype(values.dtype)


def rotate_xy_pairs(values: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rotate every consecutive (x, y) pair of the last axis.

    Args:
        values: (..., 2P) e.g. a state (x, y, vx, vy, ax, ay).
        rotation: (2, 2) or (..., 2, 2) broadcastable to the leading dimensions of ``values``.

    Returns:
        (..., 2P) rotated values. Rotation commutes with the (linear) finite differences, so
        rotating states equals recomputing them from rotated positions.
    """
    pairs = values.reshape(*values.shape[:-1], -1, 2)  # (..., P, 2)
    rotated = np.einsum("...ij,...pj->...pi", rotation, pairs)
    return rotated.reshape(values.shape)
