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


def fixed_from_body(xy_body_m: np.ndarray, pose_fixed: np.ndarray) -> np.ndarray:
    """Points given in a moving body's frame, in the fixed frame where the body is.

    Args:
        xy_body_m: (N, 2) points in the body's frame (x forward, y left), metres.
        pose_fixed: (3,) the body's pose in the fixed frame: x, y (metres), yaw (radians,
            counter-clockwise from the fixed x axis).

    Returns:
        (N, 2) the points in the fixed frame.
    """
    rotation = rotation_matrix(np.asarray(pose_fixed[2]))  # (2, 2)
    placed: np.ndarray = xy_body_m @ rotation.T + pose_fixed[:2]
    return placed


def compose_poses(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """(3,) the pose ``inner`` (given in the frame whose pose is ``outer``) in ``outer``'s
    parent frame: a sensor mounted at ``inner`` on a base at ``outer``."""
    x, y = fixed_from_body(np.asarray(inner[None, :2], dtype=np.float64), outer)[0]
    return np.array([x, y, wrap_angle(outer[2] + inner[2])])


def wrap_angle(angle_rad: np.ndarray | float) -> np.ndarray:
    """Angles wrapped into [-pi, pi)."""
    wrapped: np.ndarray = (np.asarray(angle_rad) + np.pi) % (2 * np.pi) - np.pi
    return wrapped


def yaw_of_quaternion(x: float, y: float, z: float, w: float) -> float:
    """The rotation about z (radians) of a unit quaternion (x, y, z, w), as a planar robot's
    odometry gives its heading."""
    return float(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def poses_at(
    times_s: np.ndarray, poses: np.ndarray, query_s: np.ndarray, max_gap_s: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """A body's poses interpolated at ``query_s`` between the recorded ones around each time.

    Args:
        times_s: (P,) increasing times of the recorded poses (odometry messages).
        poses: (P, 3) x, y, yaw at those times.
        query_s: (Q,) times wanted.
        max_gap_s: recorded poses further apart than this are not interpolated between.

    Returns:
        (Q, 3) poses (positions linear, yaw along the shorter turn) and (Q,) whether each time
        lay within the record (an exact time counts; outside it, or across a longer gap, the
        pose is unknown and left zero).
    """
    out = np.zeros((len(query_s), 3))
    if not len(times_s):
        return out, np.zeros(len(query_s), dtype=bool)
    after = np.searchsorted(times_s, query_s, side="left")  # (Q,) first time >= query
    safe = np.minimum(after, len(times_s) - 1)
    before = np.maximum(safe - 1, 0)
    exact = (after < len(times_s)) & (times_s[safe] == query_s)
    bracket = (after < len(times_s)) & (after > 0) & ~exact
    bracket &= times_s[safe] - times_s[before] <= max_gap_s
    out[exact] = poses[safe[exact]]
    b, a = before[bracket], safe[bracket]
    share = (query_s[bracket] - times_s[b]) / (times_s[a] - times_s[b])  # (B,)
    out[bracket, :2] = poses[b, :2] + share[:, None] * (poses[a, :2] - poses[b, :2])
    turn = wrap_angle(poses[a, 2] - poses[b, 2])
    out[bracket, 2] = wrap_angle(poses[b, 2] + share * turn)
    return out, exact | bracket
