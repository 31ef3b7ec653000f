"""ROS 2 bags of people_msgs/msg/People messages (needs the ``ros`` extra to write one)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

PEOPLE_MSGDEF = """std_msgs/Header header
people_msgs/Person[] people
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: people_msgs/Person
string name
geometry_msgs/Point position
geometry_msgs/Point velocity
float64 reliability
string[] tagnames
string[] tags
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z"""
START_S = 1_700_000_000.0  # a robot's clock: Unix time


def write_people_bag(path: Path, rows: np.ndarray, frame_id: str = "map", prefix: str = "") -> None:
    """One People message per frame of the (R, 4) ``frame, id, x, y`` rows (25 fps frames),
    each person named ``prefix`` and their id."""
    from mcap_ros2.writer import Writer

    with path.open("wb") as handle:
        writer = Writer(handle)
        schema = writer.register_msgdef("people_msgs/msg/People", PEOPLE_MSGDEF)
        for frame in np.unique(rows[:, 0]):
            now = rows[rows[:, 0] == frame]
            time_s = START_S + frame / 25.0
            sec = int(time_s)
            message = {
                "header": {
                    "stamp": {"sec": sec, "nanosec": round((time_s - sec) * 1e9)},
                    "frame_id": frame_id,
                },
                "people": [
                    {
                        "name": f"{prefix}{int(i)}",
                        "position": {"x": float(x), "y": float(y), "z": 0.0},
                        "velocity": {"x": 0.0, "y": 0.0, "z": 0.0},
                        "reliability": 1.0,
                        "tagnames": [],
                        "tags": [],
                    }
                    for _, i, x, y in now
                ],
            }
            writer.write_message("/people", schema, message, log_time=round(time_s * 1e9))
        writer.finish()
