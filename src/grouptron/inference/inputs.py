"""Checks of what callers hand the Python API: tracks and streamed frames, refused in one
clear line when malformed, never reshaped into scrambled points."""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike
from typing import Any

import numpy as np

from grouptron.config import DataConfig
from grouptron.data.formats import glitches
from grouptron.data.formats.reader import far_position
from grouptron.errors import GrouptronError

TRACK_COLUMNS = ("frame", "id", "x", "y")
MAX_EXACT_INTEGER = 2**53
"""Frames and ids travel as float64, which holds every integer exactly only below this."""


MAX_MISSED_STEPS = 2
"""Missed detections in a row a live session fills by default (``Predictor``'s
``max_missed_steps``); a longer gap restarts the track."""


def integer_argument(value: Any, name: str, minimum: int = 0, maximum: int | None = None) -> int:
    """``value`` as an int: a Python or NumPy integer (not a bool) from ``minimum`` to
    ``maximum``, or one clear line saying what it must be."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise GrouptronError(f"{name} must be an integer, not {value!r}")
    if value < minimum or (maximum is not None and value > maximum):
        bounds = f"from {minimum} to {maximum}" if maximum is not None else f">= {minimum}"
        raise GrouptronError(f"{name} must be an integer {bounds}, not {value}")
    return int(value)


def frame_argument(value: Any, name: str) -> int:
    """A frame number handed to the API: an integer, or a float holding one exactly."""
    if isinstance(value, float | np.floating) and np.isfinite(value) and value == int(value):
        value = int(value)
    return integer_argument(value, name, 1 - MAX_EXACT_INTEGER, MAX_EXACT_INTEGER - 1)


def check_track_rows(values: np.ndarray, frames_per_step: int) -> None:
    """Refuse (R, 4) finite rows whose frames or ids are not whole numbers or too large to be
    exact, that repeat a (frame, id), or whose frames are off the ``frames_per_step`` grid of
    the first frame, naming the caller's row (not a row of some internal window)."""
    for column, name in ((0, "frame"), (1, "id")):
        whole = values[:, column] == np.round(values[:, column])
        exact = np.abs(values[:, column]) < MAX_EXACT_INTEGER
        bad = np.flatnonzero(~(whole & exact))
        if bad.size:
            why = "is not a whole number" if not whole[bad[0]] else "is beyond 2**53"
            value = values[bad[0], column]
            raise GrouptronError(f"tracks row {int(bad[0])}: {name} {value:.17g} {why}")
    first = values[:, 0].min()
    off = np.flatnonzero((values[:, 0] - first) % frames_per_step)
    if off.size:
        raise GrouptronError(
            f"tracks row {int(off[0])}: frame {values[off[0], 0]:.0f} is not on the "
            f"{frames_per_step}-frame grid that starts at frame {first:.0f}"
        )
    _check_coordinates(values[:, 2:4], "tracks row")
    _, index, counts = np.unique(values[:, :2], axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        frame, ped = values[index[np.flatnonzero(counts > 1)[0]], :2]
        first, row = np.flatnonzero((values[:, 0] == frame) & (values[:, 1] == ped))[:2]
        raise GrouptronError(
            f"tracks row {row}: pedestrian {ped:.0f} appears twice at frame {frame:.0f} (also "
            f"row {first})"
        )


def as_track_array(tracks: Any) -> np.ndarray:
    """(R, 4) float64 ``frame, id, x, y`` from an array, or a table with those columns (a
    DataFrame, a dict of columns or a NumPy structured array)."""
    if isinstance(tracks, str | PathLike):
        raise GrouptronError(
            f"tracks are rows of numbers, not a file name ({tracks}): read a file with "
            "grouptron.load_tracks(path)"
        )
    names = getattr(getattr(tracks, "dtype", None), "names", None)
    if hasattr(tracks, "columns") or isinstance(tracks, Mapping) or names:
        # A table: pick the columns by name.
        present = list(tracks.columns if hasattr(tracks, "columns") else names or tracks)
        missing = [c for c in TRACK_COLUMNS if c not in present]
        if missing:
            raise GrouptronError(f"tracks lack the columns {missing} (need frame, id, x, y)")
        tracks = [np.asarray(tracks[c]) for c in TRACK_COLUMNS]
        try:
            tracks = np.column_stack([np.asarray(c, dtype=np.float64) for c in tracks])
        except (TypeError, ValueError):
            raise GrouptronError("tracks must be numbers: columns frame, id, x, y") from None
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
    bad = np.flatnonzero((ids_arr != np.round(ids_arr)) | ~(np.abs(ids_arr) < MAX_EXACT_INTEGER))
    if bad.size:
        raise GrouptronError(
            f"frame {frame}: ids must be whole numbers below 2**53, not {ids_arr[bad[0]]!r}"
        )
    if len(np.unique(ids_arr)) != len(ids_arr):
        raise GrouptronError(f"frame {frame}: an id appears twice in one frame")
    _check_coordinates(xy_arr, f"frame {frame}: row")
    return ids_arr, xy_arr


def _check_coordinates(xy_m: np.ndarray, where: str) -> None:
    """Refuse (N, 2) far positions naming the caller's row: they overflow the geometry and
    leak into every forecast."""
    found = far_position(xy_m)
    if found is not None:
        raise GrouptronError(f"{where} {found[0]}: {found[1]}")


def refuse_future_neighbours(data: DataConfig, source: str) -> None:
    """A model whose neighbours were chosen by later contacts cannot run on live tracks."""
    if data.neighbours_look_ahead:
        raise GrouptronError(
            f"{source or 'this model'} picks neighbours by whom they meet after t "
            "(data.neighbour_window_steps, a leak diagnostic): it cannot forecast live"
        )


def check_walking_speed(
    values: np.ndarray, data: DataConfig, frames_per_step: int, min_pairs: int = 1
) -> bool:
    """Refuse (R, 4) ``frame, id, x, y`` tracks whose median speed no pedestrian walks (wrong
    units or frame grid); returns whether there were ``min_pairs`` consecutive observations
    to judge."""
    seconds_per_frame = data.dt_s / frames_per_step
    time_s = values[:, 0] * seconds_per_frame
    pairs = len(values) - len(np.unique(values[:, 1]))
    if pairs < min_pairs:
        return False
    median = glitches.median_speed_mps(values[:, 1], time_s, values[:, 2:4])
    if median > glitches.MAX_MEDIAN_SPEED_MPS:
        raise GrouptronError(
            f"the tracks' median walking speed is {median:.3g} m/s with frames "
            f"{frames_per_step} apart per {data.dt_s} s step: positions "
            "must be metres (convert centimetres or millimetres) and frames on that grid; "
            "Predictor(check_speed=False) goes on anyway"
        )
    return True
