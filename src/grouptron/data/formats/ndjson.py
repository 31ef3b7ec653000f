"""The TrajNet++ ``.ndjson`` format: read its tracks, write forecasts its tools can score.

Every line is one JSON object: a scene ``{"scene": {"id", "p", "s", "e", "fps", "tag"}}``
(an interval of frames around a primary pedestrian ``p``) or a track row ``{"track": {"f",
"p", "x", "y"}}`` (frame, pedestrian, metres). Forecasts are track rows with
``prediction_number`` and ``scene_id``. Frame numbers are the source's; ``fps`` is rows per
second (2.5 for the 0.4 s step).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from grouptron.data.formats.fields import read_text_file, refuse_bad_numbers
from grouptron.errors import DataFormatError
from grouptron.io import write_text_atomically

ROWS_PER_SECOND = 2.5  # TrajNet++'s resampling: one row per 0.4 s


def read_ndjson(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(R, 4) ``frame, id, x, y`` rows of the file's tracks (each (frame, id) once), (R,) the
    file line of every row, and the seconds per frame number, from the scenes' ``fps`` (rows
    per second) and the tracks' most common frame step.

    Raises:
        DataFormatError: naming the line, for a line that is not a scene or a track, a value
            that is not finite, an id or frame that is not a whole number, or an ``fps`` that
            is not a positive number.
    """
    rows, line_of_row, fps = _entries(path)
    refuse_bad_numbers(path, rows, line_of_row, dict(enumerate("fpxy")), whole=(0, 1))
    # Scenes repeat rows: keep each (frame, id) once, from its first line; two different
    # positions for one (frame, id) are refused by the resampling's duplicate check.
    _, first = np.unique(rows, axis=0, return_index=True)
    first.sort()
    rows, line_of_row = rows[first], line_of_row[first]
    by_track = rows[np.lexsort((rows[:, 0], rows[:, 1]))]
    same_ped = by_track[1:, 1] == by_track[:-1, 1]
    steps = np.diff(by_track[:, 0])[same_ped]
    step = float(np.median(steps[steps > 0])) if (steps > 0).any() else 1.0
    if len(set(fps)) > 1:
        # One median rate would fit none of them: every time would be off.
        rates = ", ".join(f"{f:g}" for f in sorted(set(fps)))
        raise DataFormatError(
            path, f"its scenes have different fps ({rates}); split the file by rate"
        )
    rows_per_second = float(np.median(fps)) if fps else ROWS_PER_SECOND
    return rows, line_of_row, 1.0 / (rows_per_second * step)


def _entries(path: Path) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """(R, 4) every track row as written, (R,) its file line, and every scene's ``fps``."""
    rows, numbers, fps = [], [], []
    lines = read_text_file(Path(path)).splitlines()
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
            if "track" in entry:
                t = entry["track"]
                rows.append((float(t["f"]), float(t["p"]), float(t["x"]), float(t["y"])))
                numbers.append(number)
            elif "scene" in entry and "fps" in entry["scene"]:
                fps.append(float(entry["scene"]["fps"]))
                if not (math.isfinite(fps[-1]) and fps[-1] > 0):
                    why = f"fps must be a positive number, not {fps[-1]:g}"
                    raise DataFormatError(path, why, number)
        except KeyError as exc:
            why = f"a TrajNet++ track needs f, p, x and y; {exc} is missing"
            raise DataFormatError(path, why, number) from None
        except (ValueError, TypeError, AttributeError) as exc:
            raise DataFormatError(path, f"not a TrajNet++ scene or track ({exc})", number) from None
    if not rows:
        raise DataFormatError(path, "no track rows")
    return np.asarray(rows), np.asarray(numbers), fps


def write_forecast_ndjson(
    path: Path,
    frames: np.ndarray,
    ids: np.ndarray,
    positions: np.ndarray,
    history: Sequence[np.ndarray],
    *,
    frames_per_step: int,
) -> None:
    """Write forecasts as TrajNet++ predictions: one scene per (pedestrian, frame) with its
    observed rows and, per predicted future k, rows with ``prediction_number`` k.

    Args:
        frames: (N,) the frame each forecast starts from.
        ids: (N,) pedestrian ids.
        positions: (N, K, H, 2) predicted positions (K = 1 for the most likely).
        history: N arrays (T_i, 2) of the observed positions up to and including ``frame``.
        frames_per_step: frames between rows.
    """
    lines = []
    N, K, H, _ = positions.shape
    for scene_id in range(N):
        frame, ped = int(frames[scene_id]), int(ids[scene_id])
        observed = history[scene_id]
        first = frame - (len(observed) - 1) * frames_per_step
        last = frame + H * frames_per_step
        scene = {"id": scene_id, "p": ped, "s": first, "e": last, "fps": ROWS_PER_SECOND}
        lines.append(json.dumps({"scene": scene}))
        for i, (x, y) in enumerate(observed):
            row = {"f": first + i * frames_per_step, "p": ped, "x": round(float(x), 6)}
            lines.append(json.dumps({"track": {**row, "y": round(float(y), 6)}}))
        for k in range(K):
            for h in range(H):
                x, y = positions[scene_id, k, h]
                row = {"f": frame + (h + 1) * frames_per_step, "p": ped}
                row |= {"x": round(float(x), 6), "y": round(float(y), 6)}
                row |= {"prediction_number": k, "scene_id": scene_id}
                lines.append(json.dumps({"track": row}))
    write_text_atomically(Path(path), "\n".join(lines) + "\n")
