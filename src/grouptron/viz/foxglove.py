"""Forecasts as Foxglove scene messages in an MCAP file, to play back beside a robot's bag.

One ``foxglove.SceneUpdate`` message per forecast time on one topic: per person, an entity
with the point forecast as a line strip (from the last observed position) and, when regions
are asked for, each forecast step's region as a flat cylinder (its ellipse). JSON-encoded
messages with a JSON schema, which Foxglove reads as its own scene type; written with the
``mcap`` library (the ``ros`` extra).
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast

SCHEMA_NAME = "foxglove.SceneUpdate"
TOPIC = "/grouptron/forecasts"
_POINT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
SCHEMA = {
    "title": SCHEMA_NAME,
    "type": "object",
    "properties": {
        "deletions": {"type": "array"},
        "entities": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "timestamp": {"type": "object"},
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": {"type": "object"},
                    "lines": {"type": "array", "items": {"type": "object"}},
                    "cylinders": {"type": "array", "items": {"type": "object"}},
                    "texts": {"type": "array", "items": {"type": "object"}},
                },
            },
        },
    },
}
"""The parts of Foxglove's SceneUpdate schema these messages use."""
FORECAST_COLOUR = {"r": 0.1, "g": 0.45, "b": 0.9, "a": 1.0}
REGION_COLOUR = {"r": 0.1, "g": 0.45, "b": 0.9, "a": 0.15}


def _time(seconds: float) -> dict[str, int]:
    whole = int(np.floor(seconds))
    return {"sec": whole, "nsec": round((seconds - whole) * 1e9)}


def _pose(x: float, y: float, angle_rad: float = 0.0) -> dict[str, Any]:
    half = 0.5 * angle_rad  # a turn about z as a quaternion
    return {
        "position": {"x": x, "y": y, "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": float(np.sin(half)), "w": float(np.cos(half))},
    }


def scene_update(
    forecast: Forecast,
    rows: np.ndarray,
    time_s: float,
    origins: np.ndarray,
    frame_id: str,
    step_s: float,
    names: list[str],
    region: Any = None,
) -> dict[str, Any]:
    """The SceneUpdate of the (K,) forecasts ``rows`` made at ``time_s``; ``origins`` (K, 2)
    are their last observed positions, ``region`` the forecast's ``Regions`` (or None)."""
    entities = []
    for k, row in enumerate(rows):
        path = np.vstack([origins[k], forecast.most_likely[row]])
        entity: dict[str, Any] = {
            "timestamp": _time(time_s),
            "frame_id": frame_id,
            "id": f"person-{names[k]}",
            "lifetime": _time(step_s),  # replaced by the next forecast
            "frame_locked": False,
            "metadata": [{"key": "id", "value": names[k]}],
            "lines": [
                {
                    "type": 0,  # LINE_STRIP
                    "pose": _pose(0.0, 0.0),
                    "thickness": 0.06,
                    "scale_invariant": False,
                    "points": [{"x": float(x), "y": float(y), "z": 0.0} for x, y in path],
                    "color": FORECAST_COLOUR,
                    "colors": [],
                    "indices": [],
                }
            ],
            "cylinders": [],
            "texts": [],
        }
        if region is not None:
            for h in range(region.major_m.shape[1]):
                cx, cy = region.centre[row, h]
                entity["cylinders"].append(
                    {
                        "pose": _pose(float(cx), float(cy), float(region.angle_rad[row, h])),
                        "size": {
                            "x": 2 * float(region.major_m[row, h]),
                            "y": 2 * float(region.minor_m[row, h]),
                            "z": 0.01,
                        },
                        "bottom_scale": 1.0,
                        "top_scale": 1.0,
                        "color": REGION_COLOUR,
                    }
                )
        entities.append(entity)
    return {"deletions": [], "entities": entities}


def write_forecast_mcap(
    path: Path,
    forecast: Forecast,
    origins: np.ndarray,
    time_of_frame: Any,
    frame_id: str,
    step_s: float,
    name_of_id: Any = str,
    region_q: float | None = None,
) -> int:
    """Write one SceneUpdate per forecast time to ``path`` on :data:`TOPIC`; returns how many.

    Args:
        origins: (N, 2) every forecast's last observed position.
        time_of_frame: frame number -> seconds (the bag's clock for a bag's tracks).
        name_of_id: id -> the name shown (a bag's own id names).
        region_q: also draw each step's region holding this probability.
    """
    try:
        writer_module = importlib.import_module("mcap.writer")
    except ImportError:
        raise GrouptronError(
            "writing .mcap needs the ros extra: pip install 'grouptron[ros]'"
        ) from None
    region = None if region_q is None else forecast.regions(region_q)
    frames = np.unique(forecast.frames)
    with Path(path).open("wb") as handle:
        writer = writer_module.Writer(handle)
        writer.start(profile="", library="grouptron")
        schema = writer.register_schema(
            name=SCHEMA_NAME, encoding="jsonschema", data=json.dumps(SCHEMA).encode()
        )
        channel = writer.register_channel(topic=TOPIC, message_encoding="json", schema_id=schema)
        for sequence, frame in enumerate(frames):
            rows = np.flatnonzero(forecast.frames == frame)
            time_s = float(time_of_frame(int(frame)))
            names = [str(name_of_id(i)) for i in forecast.ids[rows]]
            update = scene_update(
                forecast, rows, time_s, origins[rows], frame_id, step_s, names, region
            )
            stamp = round(time_s * 1e9)
            writer.add_message(
                channel_id=channel,
                log_time=stamp,
                publish_time=stamp,
                sequence=sequence,
                data=json.dumps(update).encode(),
            )
        writer.finish()
    return len(frames)
