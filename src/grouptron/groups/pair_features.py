"""What a pair of people did over the observed window, as numbers a classifier of "walking
together" reads: distance and its trend, speeds and headings and how steady they were,
and side by side versus one behind the other.

Every feature is symmetric in the pair, so (i, j) and (j, i) read the same. Lengths are in
units of the crowd's own spacing now (the median distance to one's nearest neighbour) and
speeds in units of its median walking speed: recordings differ in both (the labelled ETH
walkers keep 1.3 m from their companions, HOTEL's 0.7 m), and a classifier of metres learns
one recording's spacing.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from grouptron.groups.distances import mean_velocities, pair_hausdorff

FEATURES = (
    "distance_now",
    "distance_mean",
    "distance_min",
    "distance_std",
    "side_by_side",
    "one_behind",
    "hausdorff",
    "distance_trend",
    "speed_low",
    "speed_high",
    "velocity_difference",
    "mean_velocity_difference",
    "heading_cos_mean",
    "heading_cos_std",
    "seen_together",
    "rule_distance_m",
)
"""The features, in column order."""
MIN_SPACING_M = 0.5
MIN_WALKING_MPS = 0.5
"""Floors of the crowd's spacing and speed units (a crowd standing shoulder to shoulder)."""
RULE_VELOCITY_WEIGHT_S = 2.0
"""The distance rule's velocity weight (``presets.DETECTION_GROUPS``), for its distance as a
feature: what the classifier may correct."""
MOVING_MPS = 0.2
"""Below this speed a heading means nothing: the heading terms count such steps as agreeing
when both stand and as disagreeing when one walks."""


def _velocities(traj: np.ndarray, mask: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(N, W, 2) backward-difference velocities and (N, W) where both ends were observed."""
    velocity = np.zeros_like(traj)
    velocity[:, 1:] = (traj[:, 1:] - traj[:, :-1]) / dt_s
    known = np.zeros_like(mask)
    known[:, 1:] = mask[:, 1:] & mask[:, :-1]
    return np.where(known[..., None], velocity, 0.0), known


def _masked_mean(values: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """(P, W) values -> (P,) their mean where ``weight`` is true (0 where never)."""
    count = weight.sum(axis=1)
    return np.where(count > 0, (values * weight).sum(axis=1) / np.maximum(count, 1), 0.0)


def pair_features(traj: np.ndarray, mask: np.ndarray, pairs: np.ndarray, dt_s: float) -> np.ndarray:
    """(P, F) the :data:`FEATURES` of (P, 2) ``pairs`` of N people with (N, W, 2) positions
    (metres) over the window and (N, W) where each was observed; the window's last step is
    now, where everyone in a pair is observed."""
    traj = traj.astype(np.float64)
    spacing, pace = crowd_units(traj, mask, dt_s)
    i, j = pairs[:, 0], pairs[:, 1]
    both = mask[i] & mask[j]  # (P, W)
    offset = traj[j] - traj[i]  # (P, W, 2)
    distance = np.hypot(offset[..., 0], offset[..., 1])
    mean_d = _masked_mean(distance, both)
    spread = np.sqrt(_masked_mean((distance - mean_d[:, None]) ** 2, both))
    first = np.argmax(both, axis=1)  # the first step both were seen
    rows = np.arange(len(pairs))
    span_s = np.maximum((both.shape[1] - 1 - first) * dt_s, dt_s)
    trend = (distance[:, -1] - distance[rows, first]) / span_s
    velocity, known = _velocities(traj, mask, dt_s)
    v_i, v_j, moving = velocity[i], velocity[j], known[i] & known[j]  # (P, W, 2), (P, W)
    speed_i = np.hypot(v_i[..., 0], v_i[..., 1])
    speed_j = np.hypot(v_j[..., 0], v_j[..., 1])
    mean_i, mean_j = _masked_mean(speed_i, moving), _masked_mean(speed_j, moving)
    difference = _masked_mean(np.hypot(*(v_i - v_j).transpose(2, 0, 1)), moving)
    walking_i, walking_j = speed_i > MOVING_MPS, speed_j > MOVING_MPS
    cos = (v_i * v_j).sum(-1) / np.maximum(speed_i * speed_j, 1e-9)
    cos = np.where(walking_i & walking_j, cos, np.where(walking_i | walking_j, -1.0, 1.0))
    cos_mean = _masked_mean(cos, moving)
    cos_std = np.sqrt(_masked_mean((cos - cos_mean[:, None]) ** 2, moving))
    heading = v_i + v_j  # (P, W, 2) the pair's direction of travel
    norm = np.hypot(heading[..., 0], heading[..., 1])
    unit = heading / np.maximum(norm, 1e-9)[..., None]
    along = np.abs((offset * unit).sum(-1))
    across = np.abs(offset[..., 0] * unit[..., 1] - offset[..., 1] * unit[..., 0])
    oriented = moving & (norm > MOVING_MPS)
    hausdorff = pair_hausdorff(traj, mask, pairs)  # the distance rule's distance
    mean_velocity = mean_velocities(traj, mask, dt_s)  # (N, 2) as the distance rule has them
    apart_mps = np.linalg.norm(mean_velocity[i] - mean_velocity[j], axis=1)
    lengths = [
        distance[:, -1],
        mean_d,
        np.where(both, distance, np.inf).min(axis=1),
        spread,
        _masked_mean(across, oriented),
        _masked_mean(along, oriented),
        hausdorff,
    ]
    speeds = [trend, np.minimum(mean_i, mean_j), np.maximum(mean_i, mean_j), difference, apart_mps]
    rule_m = np.maximum(hausdorff, RULE_VELOCITY_WEIGHT_S * apart_mps)  # as group_distances
    others = [cos_mean, cos_std, both.mean(axis=1), rule_m]
    columns = [v / spacing for v in lengths] + [v / pace for v in speeds] + others
    return np.stack(columns, axis=1).astype(np.float32)


def crowd_units(traj: np.ndarray, mask: np.ndarray, dt_s: float) -> tuple[float, float]:
    """(spacing m, pace m/s) of N people ((N, W, 2), (N, W), the last step now): the median
    distance to one's nearest neighbour now and the median speed of those who walk, each at
    least its floor."""
    now = traj[:, -1]
    spacing = MIN_SPACING_M
    if len(now) > 1:
        nearest = cKDTree(now).query(now, k=2)[0][:, 1]
        spacing = max(float(np.median(nearest)), MIN_SPACING_M)
    velocity, known = _velocities(traj, mask, dt_s)
    speed = _masked_mean(np.hypot(velocity[..., 0], velocity[..., 1]), known)
    walking = speed[speed > MOVING_MPS]
    pace = max(float(np.median(walking)), MIN_WALKING_MPS) if len(walking) else MIN_WALKING_MPS
    return spacing, pace
