"""ROS 2 bags of people_msgs/msg/People messages (needs the ``ros`` extra to write one)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np


def _msgdef(top: str, *names: str) -> str:
    """A message definition as MCAP stores it: ``top``'s fields, then each named type's."""
    rule = "=" * 80
    return "\n".join([top, *(f"{rule}\nMSG: {n}\n{_FIELDS[n]}" for n in names)])


_FIELDS = {
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
    "people_msgs/Person": "string name\ngeometry_msgs/Point position\n"
    "geometry_msgs/Point velocity\nfloat64 reliability\nstring[] tagnames\nstring[] tags",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/PoseWithCovariance": "geometry_msgs/Pose pose\nfloat64[36] covariance",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    "geometry_msgs/TwistWithCovariance": "geometry_msgs/Twist twist\nfloat64[36] covariance",
    "geometry_msgs/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
}
"""The fields of each message type the test bags use."""

PEOPLE_MSGDEF = _msgdef(
    "std_msgs/Header header\npeople_msgs/Person[] people",
    *("std_msgs/Header", "builtin_interfaces/Time", "people_msgs/Person", "geometry_msgs/Point"),
)
ODOMETRY_MSGDEF = _msgdef(
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
    "geometry_msgs/TwistWithCovariance twist",
    *("std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance"),
    *("geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion"),
    *("geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist", "geometry_msgs/Vector3"),
)
START_S = 1_700_000_000.0  # a robot's clock: Unix time


def odometry_message(time_s: float, pose: np.ndarray) -> dict:
    """A ``nav_msgs/msg/Odometry`` of a robot at (3,) ``pose`` in ``odom`` (mcap_ros2's form)."""
    sec = int(time_s)
    zero = {"x": 0.0, "y": 0.0, "z": 0.0}
    return {
        "header": {
            "stamp": {"sec": sec, "nanosec": round((time_s - sec) * 1e9)},
            "frame_id": "odom",
        },
        "child_frame_id": "base_link",
        "pose": {
            "pose": {
                "position": {"x": float(pose[0]), "y": float(pose[1]), "z": 0.0},
                "orientation": {
                    "x": 0.0,
                    "y": 0.0,
                    "z": float(np.sin(pose[2] / 2)),
                    "w": float(np.cos(pose[2] / 2)),
                },
            },
            "covariance": [0.0] * 36,
        },
        "twist": {"twist": {"linear": zero, "angular": zero}, "covariance": [0.0] * 36},
    }


def write_people_bag(
    path: Path,
    rows: np.ndarray,
    frame_id: str = "map",
    prefix: str = "",
    robot: Callable[[float], np.ndarray] | None = None,
) -> None:
    """One People message per frame of the (R, 4) ``frame, id, x, y`` rows (25 fps frames),
    each person named ``prefix`` and their id. With ``robot`` (a time's (3,) pose x, y, yaw in
    ``odom``), the people are written in ``base_link`` of a robot there, and its odometry on
    ``/odom`` at every frame's stamp and between them."""
    from mcap_ros2.writer import Writer

    with path.open("wb") as handle:
        writer = Writer(handle)
        schema = writer.register_msgdef("people_msgs/msg/People", PEOPLE_MSGDEF)
        odometry = writer.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY_MSGDEF)
        for frame in np.unique(rows[:, 0]):
            now = rows[rows[:, 0] == frame].copy()
            time_s = START_S + frame / 25.0
            if robot is not None:
                for t in (time_s - 0.2, time_s):
                    message = odometry_message(t, robot(t))
                    writer.write_message("/odom", odometry, message, log_time=round(t * 1e9))
                pose = robot(time_s)
                cos, sin = np.cos(pose[2]), np.sin(pose[2])
                dx, dy = now[:, 2] - pose[0], now[:, 3] - pose[1]
                now[:, 2], now[:, 3] = cos * dx + sin * dy, -sin * dx + cos * dy
                frame_id = "base_link"
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
