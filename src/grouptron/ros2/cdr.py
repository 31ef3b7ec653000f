"""The forecasts' ``trajectory_msgs/msg/MultiDOFJointTrajectory`` serialized directly, as the
bytes rclpy's serializer writes for ``messages.trajectory_message`` (a test compares them).

At 50 people a forecast is 600 transforms: built as Python message objects and serialized by
rclpy they take about 3 ms, written here from one NumPy array 0.05 ms
(``benchmarks/ros2_messages.py``), and the publisher sends the bytes as they are
(``Publisher.publish`` takes serialized messages).

The encoding is plain CDR, little-endian (the ``CDR_LE`` encapsulation header, then every
primitive aligned to its size counted from the header's end), which is what ROS 2's
middlewares exchange for a type without optional or keyed members.
"""

from __future__ import annotations

import struct

import numpy as np

CDR_LE = b"\x00\x01\x00\x00"
"""The encapsulation header: plain CDR, little-endian."""


class _Writer:
    """CDR primitives appended to a buffer, aligned from the end of the encapsulation."""

    def __init__(self) -> None:
        self.body = bytearray()

    def align(self, size: int) -> None:
        self.body += bytes(-len(self.body) % size)

    def uint32(self, value: int) -> None:
        self.align(4)
        self.body += struct.pack("<I", value)

    def stamp(self, sec: int, nanosec: int) -> None:
        self.align(4)
        self.body += struct.pack("<iI", sec, nanosec)

    def string(self, text: str) -> None:
        data = text.encode()
        self.uint32(len(data) + 1)  # the length counts the closing NUL
        self.body += data + b"\x00"


def trajectory_bytes(
    ids: list[str], point: np.ndarray, sec: int, nanosec: int, frame_id: str, dt_s: float
) -> bytes:
    """The serialized ``MultiDOFJointTrajectory`` of ``trajectory_message``: header (``sec``,
    ``nanosec``, ``frame_id``), ``joint_names`` the N ``ids``, and for each step k = 1..H of
    the (N, H, 2) ``point`` forecast a point of N transforms (translation x, y, 0; rotation
    the identity) at ``time_from_start`` k x ``dt_s``."""
    out = _Writer()
    out.stamp(sec, nanosec)
    out.string(frame_id)
    out.uint32(len(ids))
    for name in ids:
        out.string(name)
    people, horizon = point.shape[0], point.shape[1]
    out.uint32(horizon)
    transforms = np.zeros((horizon, people, 7))  # translation x y z, rotation x y z w
    transforms[..., :2] = point.transpose(1, 0, 2)
    transforms[..., 6] = 1.0
    blocks = transforms.astype("<f8")
    for k in range(horizon):  # 12 steps, each one NumPy block of N transforms
        out.uint32(people)
        if people:
            out.align(8)
            out.body += blocks[k].tobytes()
        out.uint32(0)  # velocities
        out.uint32(0)  # accelerations
        seconds = (k + 1) * dt_s
        out.stamp(int(seconds), round((seconds % 1) * 1e9))
    return CDR_LE + bytes(out.body)
