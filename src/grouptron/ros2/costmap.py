"""The forecasts as a costmap a planner reads: the q-regions drawn into a grid (no graph here).

The rule: a cell whose centre lies inside the q-region of some person's step k (k = 1 .. K,
``steps``) costs ``round(100 * (K - k + 1) / K)``: 100 (occupied) where someone is expected in
0.4 s, falling linearly to ``100 / K`` at the last step drawn; the cell keeps the highest cost
of the regions it lies in, and cells in none are 0 (free). A region is cut to ``REACH_M`` around
its step's point forecast, so that a far step's wide ellipse does not close a corridor: every
cell farther than that from every point forecast is free. The grid is a window of
``size_m`` x ``size_m`` at ``resolution_m``, centred on the robot (with odometry) or on a fixed
point, in the forecasts' fixed frame; ``nav_msgs/msg/OccupancyGrid`` (row-major from the
window's corner, x along a row) is written directly as bytes, like the forecasts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grouptron.model.regions import Regions
from grouptron.ros2.cdr import CDR_LE, CdrWriter

REACH_M = 3.0
"""A region is drawn at most this far from its step's point forecast."""
MAX_COST = 100
"""``nav_msgs/msg/OccupancyGrid``'s occupied: the cost of a region at the first step."""


@dataclass(frozen=True)
class CostmapWindow:
    """Where the costmap is drawn.

    Attributes:
        size_m: the window's side, metres.
        resolution_m: a cell's side, metres.
        steps: the forecast steps drawn (K, at most the horizon).
    """

    size_m: float = 20.0
    resolution_m: float = 0.1
    steps: int = 12

    @property
    def cells(self) -> int:
        """Cells along a side."""
        return max(1, round(self.size_m / self.resolution_m))

    def corner(self, centre_xy: np.ndarray) -> np.ndarray:
        """(2,) the window's lower-left corner for a window centred at (2,) ``centre_xy``,
        snapped to the cell grid so that a moving window does not shimmer."""
        corner: np.ndarray = np.floor((centre_xy - self.size_m / 2) / self.resolution_m)
        return corner * self.resolution_m


def step_costs(steps: int) -> np.ndarray:
    """(K,) int8 the cost of step k = 1 .. K (module docstring)."""
    k = np.arange(1, steps + 1)
    costs: np.ndarray = np.round(MAX_COST * (steps - k + 1) / steps).astype(np.int8)
    return costs


def region_costmap(regions: Regions, window: CostmapWindow, corner_xy: np.ndarray) -> np.ndarray:
    """(C, C) int8 costs of the window whose lower-left corner is (2,) ``corner_xy``: row i is
    y = corner + (i + 0.5) resolution, column j likewise x (module docstring's rule).

    Drawn row by row: on each grid row an ellipse (cut to ``REACH_M``) covers one interval of
    cells, found from its quadratic; the intervals of every ellipse, row and step are laid
    out as one array of cells, and each cell keeps the first step that covers it
    (``np.minimum.at``). No cell is tested against an ellipse."""
    cells = window.cells
    steps = min(window.steps, regions.centre.shape[1])
    if not len(regions.centre) or steps == 0:
        return np.zeros((cells, cells), dtype=np.int8)
    people = len(regions.centre)
    row, start, stop, step = _intervals(  # the ellipses step by step: step k's are block k
        regions.centre[:, :steps].transpose(1, 0, 2).reshape(-1, 2),
        regions.major_m[:, :steps].T.ravel(),
        regions.minor_m[:, :steps].T.ravel(),
        regions.angle_rad[:, :steps].T.ravel(),
        corner_xy,
        window,
    )
    step = (step // people).astype(np.uint8)  # (P,) the step of each run's ellipse
    width = stop - start
    # (T,) the flat index of every covered cell: its run's first cell, counted on from there
    # (int32: a window has at most 4000 x 4000 cells, and half the bytes to move).
    base = (row * cells + start - (np.cumsum(width) - width)).astype(np.int32)
    covered = np.repeat(base, width)
    covered += np.arange(len(covered), dtype=np.int32)
    first = np.full(cells * cells, steps, dtype=np.uint8)  # steps: no step covers the cell
    np.minimum.at(first, covered, np.repeat(step, width))
    costs = np.append(step_costs(steps), np.int8(0))
    grid: np.ndarray = costs[first].reshape(cells, cells)
    return grid


def _intervals(
    centre: np.ndarray,
    major_m: np.ndarray,
    minor_m: np.ndarray,
    angle_rad: np.ndarray,
    corner_xy: np.ndarray,
    window: CostmapWindow,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(P,) row, first column, column past the last and ellipse of every run of cells whose
    centres lie inside one of the E ellipses ((E, 2) centres, (E,) semi-axes and angles)
    and within ``REACH_M`` of its centre; empty runs left out."""
    cells, res = window.cells, window.resolution_m
    cos, sin = np.cos(angle_rad), np.sin(angle_rad)
    a2, b2 = np.maximum(major_m, 1e-9) ** 2, np.maximum(minor_m, 1e-9) ** 2
    # The ellipse as quad_x dx^2 + 2 quad_xy dx dy + quad_y dy^2 <= 1.
    quad_x, quad_y = cos**2 / a2 + sin**2 / b2, sin**2 / a2 + cos**2 / b2
    quad_xy = cos * sin * (1 / a2 - 1 / b2)
    half_y = np.minimum(np.sqrt(major_m**2 * sin**2 + minor_m**2 * cos**2), REACH_M)  # (E,)
    first = np.clip(np.floor((centre[:, 1] - half_y - corner_xy[1]) / res - 0.5) + 1, 0, cells)
    last = np.clip(np.floor((centre[:, 1] + half_y - corner_xy[1]) / res - 0.5), -1, cells - 1)
    count = np.maximum(last - first + 1, 0).astype(np.int64)  # (E,) rows each ellipse spans
    owner = np.repeat(np.arange(len(centre)), count)  # (P,) the ellipse of each run
    row = (
        first.astype(np.int64)[owner]
        + np.arange(count.sum())
        - np.repeat(np.cumsum(count) - count, count)
    )
    dy = corner_xy[1] + (row + 0.5) * res - centre[owner, 1]
    qx, qxy = quad_x[owner], quad_xy[owner]
    discriminant = (qxy * dy) ** 2 - qx * (quad_y[owner] * dy**2 - 1.0)
    root = np.sqrt(np.maximum(discriminant, 0.0))
    reach = np.sqrt(np.maximum(REACH_M**2 - dy**2, 0.0))
    low = np.maximum((-qxy * dy - root) / qx, -reach) + centre[owner, 0] - corner_xy[0]
    high = np.minimum((-qxy * dy + root) / qx, reach) + centre[owner, 0] - corner_xy[0]
    start = np.clip(np.floor(low / res - 0.5) + 1, 0, cells).astype(np.int64)
    stop = np.clip(np.floor(high / res - 0.5) + 1, 0, cells).astype(np.int64)
    keep = (discriminant >= 0) & (stop > start)
    return row[keep], start[keep], stop[keep], owner[keep]


def occupancy_grid_bytes(
    grid: np.ndarray, stamp: tuple[int, int], frame_id: str, corner_xy: np.ndarray, res: float
) -> bytes:
    """The serialized ``nav_msgs/msg/OccupancyGrid`` of (C, C) int8 ``grid``: stamped and
    framed as given, its origin the window's corner (identity orientation)."""
    out = CdrWriter()
    out.stamp(*stamp)
    out.string(frame_id)
    out.stamp(*stamp)  # info.map_load_time
    out.float32s((res,))
    out.uint32(grid.shape[1])  # width: cells along x
    out.uint32(grid.shape[0])  # height
    out.float64s(np.array([corner_xy[0], corner_xy[1], 0.0, 0.0, 0.0, 0.0, 1.0]))
    out.uint32(grid.size)
    out.body += np.ascontiguousarray(grid, dtype=np.int8).tobytes()
    return CDR_LE + bytes(out.body)
