"""Forecast files made elsewhere (or by ``grouptron predict``), read as rows to be scored:
CSV layout 2 (``frame,id,step,x_m,y_m`` with optional ``t_s``, ``sample`` and region columns;
layout 1's ``x,y`` too) and TrajNet++ ``.ndjson`` predictions (track rows with
``prediction_number`` and ``scene_id``)."""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.data.formats.fields import read_text_file
from grouptron.errors import DataFormatError

CSV_COLUMNS = ("frame", "id", "step", "x_m", "y_m")
LAYOUT_1_COLUMNS = ("frame", "id", "step", "x", "y")


@dataclass(frozen=True)
class ForecastRows:
    """One position of one forecast per row (R rows).

    Attributes:
        frame: (R,) the forecast time as the recording's own frame number.
        ids: (R,) the person.
        step: (R,) k = 1..H, the position k steps after the forecast time.
        xy_m: (R, 2) metres, in the recording's frame of reference.
        sample: (R,) which sampled future, or None for a file of point forecasts.
    """

    frame: np.ndarray
    ids: np.ndarray
    step: np.ndarray
    xy_m: np.ndarray
    sample: np.ndarray | None


def read_forecast_file(path: Path) -> ForecastRows:
    """The rows of a ``.ndjson`` TrajNet++ prediction file, else of a CSV file with a header.

    Raises:
        DataFormatError: naming the file (and line), for a file without the columns, with
            numbers that do not read, steps below 1 or positions that are not finite.
    """
    path = Path(path)
    rows = _ndjson_rows(path) if path.suffix == ".ndjson" else _csv_rows(path)
    if not len(rows.frame):
        raise DataFormatError(path, "no forecast rows")
    if not np.isfinite(rows.xy_m).all():
        raise DataFormatError(path, "positions that are not finite numbers")
    if (rows.step < 1).any():
        raise DataFormatError(path, "steps count from 1 (the first position after the frame)")
    return rows


def _csv_rows(path: Path) -> ForecastRows:
    """CSV rows, the columns found by the header's names."""
    text = read_text_file(path)
    header = [name.strip() for name in text.split("\n", 1)[0].split(",")]
    names = CSV_COLUMNS if "x_m" in header else LAYOUT_1_COLUMNS
    missing = [name for name in names if name not in header]
    if missing:
        raise DataFormatError(
            path,
            f"a forecast file needs the columns {', '.join(CSV_COLUMNS)} (and sample for "
            f"sampled futures); {', '.join(missing)} missing from its header",
            1,
        )
    wanted = [header.index(name) for name in names]
    sampled = "sample" in header
    if sampled:
        wanted.append(header.index("sample"))
    try:
        values = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, usecols=wanted, ndmin=2)
    except ValueError as exc:
        raise DataFormatError(path, f"a row that does not read as numbers ({exc})") from None
    return ForecastRows(
        frame=values[:, 0].astype(np.int64),
        ids=values[:, 1],
        step=values[:, 2].astype(np.int64),
        xy_m=values[:, 3:5],
        sample=values[:, 5].astype(np.int64) if sampled else None,
    )


def _ndjson_rows(path: Path) -> ForecastRows:
    """Prediction rows of each (scene, person, prediction number), in frame order: the first
    is step 1, and the forecast time is one frame step before it."""
    found = []
    for number, line in enumerate(read_text_file(path).splitlines(), start=1):
        if '"prediction_number"' not in line:
            continue  # scenes and observed rows
        try:
            t = json.loads(line)["track"]
            values = (t["scene_id"], t["p"], t["prediction_number"], t["f"], t["x"], t["y"])
            found.append(tuple(float(v) for v in values))
        except (KeyError, ValueError, TypeError) as exc:
            why = f"a TrajNet++ prediction needs scene_id, p, prediction_number, f, x, y ({exc})"
            raise DataFormatError(path, why, number) from None
    if not found:
        raise DataFormatError(path, "no prediction rows (track rows with prediction_number)")
    rows = np.asarray(found)  # (R, 6)
    rows = rows[np.lexsort((rows[:, 3], rows[:, 2], rows[:, 1], rows[:, 0]))]
    key = rows[:, :3]
    starts = np.flatnonzero(np.r_[True, (key[1:] != key[:-1]).any(axis=1)])
    lengths = np.diff(np.r_[starts, len(rows)])
    if (lengths < 2).any():
        raise DataFormatError(path, "a prediction with fewer than 2 future rows")
    step = np.arange(len(rows)) - np.repeat(starts, lengths) + 1  # 1.. within each prediction
    first = rows[starts, 3]
    frame_step = rows[starts + 1, 3] - first
    origin = np.repeat(first - frame_step, lengths)
    return ForecastRows(
        frame=origin.astype(np.int64),
        ids=rows[:, 1],
        step=step.astype(np.int64),
        xy_m=rows[:, 4:6],
        sample=rows[:, 2].astype(np.int64),
    )
