"""The costmap's rule on hand-made regions, and its message's bytes."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.model.regions import Regions
from grouptron.ros2.costmap import (
    REACH_M,
    CostmapWindow,
    occupancy_grid_bytes,
    region_costmap,
    step_costs,
)


def _regions(centres: np.ndarray, major: np.ndarray, minor: np.ndarray, angle: np.ndarray):
    return Regions(q=0.9, centre=centres, major_m=major, minor_m=minor, angle_rad=angle)


def _cell_centres(window: CostmapWindow, corner: np.ndarray) -> np.ndarray:
    """(C, C, 2) x, y of every cell's centre (row i: y, column j: x)."""
    offsets = (np.arange(window.cells) + 0.5) * window.resolution_m
    x, y = np.meshgrid(corner[0] + offsets, corner[1] + offsets)
    return np.stack([x, y], axis=-1)


def test_costs_fall_with_the_step_and_cells_keep_the_highest() -> None:
    assert step_costs(12).tolist()[:2] == [100, 92] and step_costs(12)[-1] == 8
    window = CostmapWindow(size_m=10.0, resolution_m=0.1, steps=3)
    corner = window.corner(np.zeros(2))
    # One person: steps 1-3 at x = 0, 1, 2, circles of radius 0.5, 0.8 and 1.0 m.
    centres = np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]])
    radius = np.array([[0.5, 0.8, 1.0]])
    grid = region_costmap(_regions(centres, radius, radius, np.zeros((1, 3))), window, corner)
    xy = _cell_centres(window, corner)
    near = [
        np.linalg.norm(xy - c, axis=-1) <= r for c, r in zip(centres[0], radius[0], strict=True)
    ]
    costs = step_costs(3)
    expected = np.zeros(grid.shape, dtype=np.int8)
    for k in (2, 1, 0):
        expected[near[k]] = costs[k]
    np.testing.assert_array_equal(grid, expected)


def test_every_cell_inside_a_region_costs_and_far_cells_are_free() -> None:
    rng = np.random.default_rng(3)
    people, steps = 20, 12
    window = CostmapWindow(size_m=20.0, resolution_m=0.1, steps=steps)
    corner = window.corner(np.array([1.0, -2.0]))
    walk = np.cumsum(rng.normal(0.4, 0.2, (people, steps, 2)), axis=1)
    centres = rng.uniform(-9, 9, (people, 1, 2)) + walk - walk[:, :1]
    major = np.linspace(0.3, 4.5, steps)[None].repeat(people, 0)  # the last ones beyond reach
    minor = 0.4 * major
    angle = rng.uniform(-1.5, 1.5, (people, steps))
    grid = region_costmap(_regions(centres, major, minor, angle), window, corner)
    xy = _cell_centres(window, corner)  # (C, C, 2)
    d = xy[:, :, None, None, :] - centres[None, None]  # (C, C, N, K, 2)
    cos, sin = np.cos(angle), np.sin(angle)
    along = (d[..., 0] * cos + d[..., 1] * sin) / major
    across = (-d[..., 0] * sin + d[..., 1] * cos) / minor
    distance = np.linalg.norm(d, axis=-1)
    inside = (along**2 + across**2 <= 1.0) & (distance <= REACH_M)
    assert (grid[inside.any(axis=(2, 3))] > 0).all()
    assert (grid[distance.min(axis=(2, 3)) > REACH_M] == 0).all()
    assert (grid > 0).sum() == inside.any(axis=(2, 3)).sum()  # nothing else


def test_the_grid_reads_back_as_an_occupancy_grid() -> None:
    pytest.importorskip("nav_msgs")
    from nav_msgs.msg import OccupancyGrid
    from rclpy.serialization import deserialize_message

    grid = np.arange(12, dtype=np.int8).reshape(3, 4)
    data = occupancy_grid_bytes(grid, (1_700_000_000, 5), "odom", np.array([-1.5, 2.0]), 0.1)
    message = deserialize_message(data, OccupancyGrid)
    assert (message.header.frame_id, message.header.stamp.nanosec) == ("odom", 5)
    assert (message.info.width, message.info.height) == (4, 3)
    assert message.info.resolution == pytest.approx(0.1)
    assert (message.info.origin.position.x, message.info.origin.position.y) == (-1.5, 2.0)
    assert message.info.origin.orientation.w == 1.0
    assert list(message.data) == grid.ravel().tolist()
