"""Rotation augmentation: turn a sample's whole scene (ego and neighbours together).

The reference rotates the centred scene by one of 24 angles and recomputes the derivatives. Both
derivative schemes are linear in the positions, so that equals rotating every (x, y) pair of
the samples' vectors, which is what is done here, with no rebuilding. (The reference rotates the
ego but not its neighbours; here both turn.)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from grouptron.data.prepare.samples import PER_EDGE, SampleSet
from grouptron.geometry import rotate_rows, rotation_matrix

ROTATION_ANGLES_DEG = np.arange(0.0, 360.0, 15.0)
"""The 24 augmentation angles of the reference: 0, 15, ..., 345 degrees."""

_ROTATED_FIELDS = (
    "pos_now_scene_m",
    "hist_rel_m",
    "hist_st",
    "fut_rel_m",
    "nbr_sum_st",
    "nbr_hist_st",
)


def draw_rotation_angles(rng: np.random.Generator, count: int) -> np.ndarray:
    """(count,) angles in radians, each one of the 24 reference angles, uniformly."""
    return np.deg2rad(rng.choice(ROTATION_ANGLES_DEG, size=count))


def rotate_samples(samples: SampleSet, angles_rad: np.ndarray) -> SampleSet:
    """Rotate every sample's scene about the scene centre by its own angle.

    Args:
        samples: S samples.
        angles_rad: (S,) counter-clockwise angles.
    """
    rotation = rotation_matrix(angles_rad)  # (S, 2, 2)
    per_edge_rotation = np.repeat(rotation, samples.num_neighbours, axis=0)  # (E, 2, 2)
    changes = {
        name: rotate_rows(
            getattr(samples, name), per_edge_rotation if name in PER_EDGE else rotation
        )
        for name in _ROTATED_FIELDS
    }
    return dataclasses.replace(samples, **changes)
