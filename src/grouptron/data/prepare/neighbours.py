"""Who is near whom: perception-range edges between pedestrians and their ramp-in weights.

Everything is computed for all steps of a scene at once from the rows that share a step, with
no Python loop over steps, agents or pairs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from grouptron.data.prepare.scene import Scene
from grouptron.errors import GrouptronError

MAX_NEIGHBOURS = 200
"""More pedestrians than this within the perception radius of one is not a crowd (a crush is
~6 per m^2, ~170 in 3 m) but a unit error; it would also make clustering explode."""


@dataclass(frozen=True)
class Edges:
    """Directed edges ``src -> dst`` (both directions are present), sorted by (src, step, dst).

    Attributes:
        src: (E,) track of the ego.
        dst: (E,) track of the neighbour.
        step: (E,) step at which the two are within the perception radius.
        weight: (E,) ramp-in weight ``min(1, sum_k w_k e_{t-k})`` in (0, 1].
    """

    src: np.ndarray
    dst: np.ndarray
    step: np.ndarray
    weight: np.ndarray


def pairs_within(
    scene: Scene, radius_m: float, rows: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs of distinct rows at the same step within ``radius_m`` of each other
    (among ``rows``; default all), found with a k-d tree: the step is a third coordinate
    farther apart than the radius, so only pairs of one step can be close.

    Returns:
        Two (P,) arrays of row indices into the scene's rows.
    """
    rows = np.arange(len(scene.step)) if rows is None else rows
    pos = scene.state_scene[rows, :2]
    apart = 4.0 * radius_m + 1.0  # between two steps: never within the radius
    points = np.column_stack([pos, scene.step[rows] * apart])
    # The tree's own arithmetic screens with a margin; the exact test below decides.
    candidates = cKDTree(points).query_pairs(radius_m * 1.0001 + 1e-9, output_type="ndarray")
    exact = np.linalg.norm(pos[candidates[:, 0]] - pos[candidates[:, 1]], axis=-1) <= radius_m
    first, second = rows[candidates[exact, 0]], rows[candidates[exact, 1]]
    return np.concatenate([first, second]), np.concatenate([second, first])


def perception_edges(
    scene: Scene, radius_m: float, ramp_weights: tuple[float, ...], from_step: int = 0
) -> Edges:
    """Edges between pedestrians present at the same step within ``radius_m`` of each other.

    The weight ramps a new edge in: ``min(1, w_0 e_t + w_1 e_{t-1} + ...)`` with ``e_s`` = 1
    where the pair was within range at step ``s``; an edge leaves at once when out of range.
    Only steps from ``from_step`` on are looked at: the weights are exact from
    ``from_step + len(ramp_weights) - 1`` on (live forecasting needs only the last step).
    """
    rows = np.flatnonzero(scene.step >= from_step) if from_step > 0 else None
    row_a, row_b = pairs_within(scene, radius_m, rows)
    _check_density(scene, row_a, radius_m)
    src, dst, step = scene.track[row_a], scene.track[row_b], scene.step[row_a]

    num_tracks, num_steps = scene.num_tracks, scene.num_steps
    key = (src.astype(np.int64) * num_tracks + dst) * num_steps + step
    order = np.argsort(key)
    key, src, dst, step = key[order], src[order], dst[order], step[order]

    weight = np.full(len(key), ramp_weights[0])
    for lag, w in enumerate(ramp_weights[1:], start=1):  # a handful of lags, not a data loop
        query = key - lag
        at = np.minimum(np.searchsorted(key, query), max(len(key) - 1, 0))
        was_edge = (step >= lag) & (key[at] == query) if len(key) else np.zeros(0, bool)
        weight = weight + w * was_edge
    weight = np.minimum(weight, 1.0)

    by_src_step = np.lexsort((dst, step, src))
    return Edges(
        src=src[by_src_step],
        dst=dst[by_src_step],
        step=step[by_src_step],
        weight=weight[by_src_step],
    )


def _check_density(scene: Scene, row_a: np.ndarray, radius_m: float) -> None:
    """Refuse a pedestrian with more than MAX_NEIGHBOURS others within ``radius_m``."""
    if not len(row_a):
        return
    counts = np.bincount(row_a, minlength=len(scene.step))
    worst = int(counts.argmax())
    if counts[worst] > MAX_NEIGHBOURS:
        frame = scene.first_frame + int(scene.step[worst]) * scene.frames_per_step
        raise GrouptronError(
            f"{scene.name}: pedestrian {scene.ped_id[scene.track[worst]]} has {counts[worst]} "
            f"others within {radius_m:g} m at frame {frame} (at most {MAX_NEIGHBOURS}); are the "
            "positions in metres?"
        )


def scene_conditions(scene: Scene, radius_m: float) -> tuple[float, float]:
    """The site's conditions, to tell whether a calibration made elsewhere fits it: the
    median number of people within ``radius_m`` of each person at each step, and the median
    walking speed (m/s; from each track's consecutive steps)."""
    if not len(scene.step):
        return math.nan, math.nan
    first, _ = pairs_within(scene, radius_m)
    neighbours = np.bincount(first, minlength=len(scene.step))
    speed = np.hypot(scene.state_scene[:, 2], scene.state_scene[:, 3])  # (R,) m/s
    moving = np.ones(len(speed), dtype=bool)
    moving[np.flatnonzero(np.diff(scene.track, prepend=-1))] = False  # a track's first row
    speeds = speed[moving] if moving.any() else speed
    return float(np.median(neighbours)), float(np.median(speeds))
