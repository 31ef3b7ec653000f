"""Checks of what callers hand the Python API: tracks and streamed frames, refused in one
clear line when malformed, never reshaped into scrambled points."""

from __future__ import annotations

from typing import Any

import numpy as np

from grouptron.config import DataConfig
from grouptron.errors import GrouptronError

TRACK_COLUMNS = ("frame", "id", "x", "y")


def as_track_array(tracks: Any) -> np.ndarray:
    """(R, 4) float64 ``frame, id, x, y`` from an array or a table with those columns."""
    if hasattr(tracks, "columns"):  # a DataFrame-like table: pick the columns by name
        missing = [c for c in TRACK_COLUMNS if c not in list(tracks.columns)]
        if missing:
            raise GrouptronError(f"tracks lack the columns {missing} (need frame, id, x, y)")
        tracks = np.column_stack([np.asarray(tracks[c], dtype=np.float64) for c in TRACK_COLUMNS])
    try:
        values = np.asarray(tracks, dtype=np.float64)
    except (TypeError, ValueError):
        raise GrouptronError("tracks must be numbers: rows of frame, id, x, y") from None
    if values.ndim != 2 or values.shape[1] != 4:
        raise GrouptronError(
            f"tracks must have shape (rows, 4) = frame, id, x, y; got {values.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise GrouptronError(f"tracks row {int(bad[0])} is not finite: {values[bad[0]].tolist()}")
    return values


def frame_arrays(frame: int, ids: Any, xy: Any) -> tuple[np.ndarray, np.ndarray]:
    """(N,) ids and (N, 2) positions of one frame, checked strictly: a (2, N) array, ids of
    another length or repeated ids are refused, never reshaped into scrambled points."""
    try:
        ids_arr = np.asarray(ids, dtype=np.float64)
        xy_arr = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        raise GrouptronError(f"frame {frame}: ids and positions must be numbers") from None
    if ids_arr.ndim != 1:
        raise GrouptronError(f"frame {frame}: ids must be a 1-d array, got shape {ids_arr.shape}")
    if len(ids_arr) == 0 and xy_arr.size == 0:
        return ids_arr, np.zeros((0, 2))
    if xy_arr.shape != (len(ids_arr), 2):
        raise GrouptronError(
            f"frame {frame}: positions must have shape (N, 2) = ({len(ids_arr)}, 2) for "
            f"{len(ids_arr)} ids, got {xy_arr.shape} (one row of x, y per person; a (2, N) "
            "array needs transposing)"
        )
    if len(np.unique(ids_arr)) != len(ids_arr):
        raise GrouptronError(f"frame {frame}: an id appears twice in one frame")
    return ids_arr, xy_arr


def refuse_future_neighbours(data: DataConfig, source: str) -> None:
    """A model whose neighbours were chosen by later contacts cannot run on live tracks."""
    if data.neighbours_look_ahead:
        raise GrouptronError(
            f"{source or 'this model'} picks neighbours by whom they meet after t "
            "(data.neighbour_window_steps, a leak diagnostic): it cannot forecast live"
        )
