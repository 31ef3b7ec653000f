"""A scene: one recording's tracks in a centred frame with per-step states."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import DT_S
from grouptron.data.formats.reader import MAX_GRID_CELLS, TrackTable
from grouptron.errors import GrouptronError
from grouptron.geometry import track_states

MAX_CO_PRESENT_PAIRS = 20_000_000
"""Bound on the sum over steps of (pedestrians at the step)^2, the pairs whose distances are
computed (about 2 GB of temporaries at the bound; ~4,500 people in a single step)."""


@dataclass(frozen=True)
class Scene:
    """One recording (one file) as gap-free tracks with position, velocity and acceleration.

    Positions are centred on the mean of all the file's positions (``pos_scene = pos_world -
    centre_world_m``), as the reference does; this only matters for rotation augmentation.

    Attributes:
        name: usually the file name without extension.
        first_frame: frame number of step 0; ``frame = first_frame + step * frames_per_step``.
        frames_per_step: frames between steps.
        centre_world_m: (2,) mean position subtracted from the world coordinates.
        ped_id: (A,) pedestrian id of every track as written in the file.
        track_first_step: (A,) first step of every track.
        track_num_points: (A,) points of every track (>= 2; >= 1 under strictly causal
            ``backward`` derivatives, see :func:`build_scene`).
        num_steps: steps from 0 to the last annotated one, inclusive.
        track: (R,) track of every row; rows are sorted by (track, step).
        step: (R,) step of every row.
        state_scene: (R, 6) x, y, vx, vy, ax, ay in the centred scene frame (m, m/s, m/s^2).
        dt_s: seconds per step (``DataConfig.dt_s``).
    """

    name: str
    first_frame: int
    frames_per_step: int
    centre_world_m: np.ndarray
    ped_id: np.ndarray
    track_first_step: np.ndarray
    track_num_points: np.ndarray
    num_steps: int
    track: np.ndarray
    step: np.ndarray
    state_scene: np.ndarray
    dt_s: float = DT_S

    @property
    def num_tracks(self) -> int:
        """Number of tracks (A)."""
        return len(self.ped_id)

    @property
    def track_last_step(self) -> np.ndarray:
        """(A,) last step of every track."""
        return self.track_first_step + self.track_num_points - 1

    def present_per_step(self) -> np.ndarray:
        """(num_steps,) pedestrians present at every step."""
        return np.bincount(self.step, minlength=self.num_steps)


def build_scene(table: TrackTable, config: DataConfig, name: str | None = None) -> Scene:
    """Turn a validated track table into a :class:`Scene`.

    Tracks with fewer than 2 points are dropped (they have no velocity), after the centre is
    taken over all of the file's positions; except under strictly causal ``backward``
    derivatives, where a person seen once is kept (velocity 0, as at every track's start) so
    that a neighbour first seen at t counts the same whether or not the recording goes on.
    """
    centre = table.pos_m.mean(axis=0)
    points_per_track = np.bincount(table.track)
    causal = config.derivatives == "backward" and config.backward_start == "zero"
    keep_track = points_per_track >= (1 if causal else 2)
    keep_row = keep_track[table.track]
    new_index = np.cumsum(keep_track) - 1  # old track -> new contiguous track
    track = new_index[table.track[keep_row]]
    step = table.step[keep_row]
    pos_scene = table.pos_m[keep_row] - centre
    state = track_states(pos_scene, track, config.dt_s, config.derivatives, config.backward_start)

    num_tracks = int(keep_track.sum())
    name = name if name is not None else table.path.stem
    _check_size(name, table, num_tracks, step)
    first_row = np.searchsorted(track, np.arange(num_tracks))
    return Scene(
        name=name,
        first_frame=table.first_frame,
        frames_per_step=table.frames_per_step,
        centre_world_m=centre,
        ped_id=table.ped_id[keep_row][first_row],
        track_first_step=step[first_row],
        track_num_points=points_per_track[keep_track],
        num_steps=int(table.step.max()) + 1,
        track=track,
        step=step,
        state_scene=state,
        dt_s=config.dt_s,
    )


def _check_size(name: str, table: TrackTable, num_tracks: int, step: np.ndarray) -> None:
    """Refuse recordings whose dense grids or pair lists would not fit in memory."""
    num_steps = int(table.step.max()) + 1
    if num_tracks * num_steps > MAX_GRID_CELLS:
        last = table.first_frame + (num_steps - 1) * table.frames_per_step
        raise GrouptronError(
            f"{name}: {num_tracks} tracks over {num_steps} steps (frames {table.first_frame} to "
            f"{last}) is too large to process at once; split the recording into separate "
            "files (e.g. at its long pauses)"
        )
    per_step = np.bincount(step, minlength=num_steps) if len(step) else np.zeros(1, np.int64)
    if int((per_step.astype(np.int64) ** 2).sum()) > MAX_CO_PRESENT_PAIRS:
        busiest = int(per_step.argmax())
        raise GrouptronError(
            f"{name}: {int(per_step[busiest])} pedestrians at once at frame "
            f"{table.first_frame + busiest * table.frames_per_step}; too many pairs to compare "
            f"(at most {MAX_CO_PRESENT_PAIRS:,} pedestrian pairs over all steps)"
        )
