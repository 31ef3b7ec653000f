"""The forecasts' ``trajectory_msgs/msg/MultiDOFJointTrajectory`` and the light markers'
``visualization_msgs/msg/MarkerArray`` serialized directly, as the bytes rclpy's serializer
writes for ``messages.trajectory_message`` and ``markers.marker_message`` (tests compare
them).

At 50 people a forecast is 600 transforms: built as Python message objects and serialized by
rclpy they take about 3 ms, written here from one NumPy array 0.05 ms
(``benchmarks/ros2_messages.py``), and the publisher sends the bytes as they are
(``Publisher.publish`` takes serialized messages). The light markers of 90 people, 1,620
points, took 16 ms as message objects.

The encoding is plain CDR, little-endian (the ``CDR_LE`` encapsulation header, then every
primitive aligned to its size counted from the header's end), which is what ROS 2's
middlewares exchange for a type without optional or keyed members.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

CDR_LE = b"\x00\x01\x00\x00"
"""The encapsulation header: plain CDR, little-endian."""


class CdrWriter:
    """CDR primitives appended to a buffer, aligned from the end of the encapsulation."""

    def __init__(self) -> None:
        self.body = bytearray()

    def align(self, size: int) -> None:
        """Pad to a multiple of ``size`` bytes."""
        self.body += bytes(-len(self.body) % size)

    def uint32(self, value: int) -> None:
        """An unsigned 32-bit integer (a sequence's length, too)."""
        self.align(4)
        self.body += struct.pack("<I", value)

    def stamp(self, sec: int, nanosec: int) -> None:
        """A ``builtin_interfaces`` Time or Duration."""
        self.align(4)
        self.body += struct.pack("<iI", sec, nanosec)

    def int32(self, value: int) -> None:
        """A signed 32-bit integer."""
        self.align(4)
        self.body += struct.pack("<i", value)

    def float64s(self, values: np.ndarray) -> None:
        """Float64 values in a row (no count: fixed-size fields, or after ``uint32``)."""
        self.align(8)
        self.body += np.ascontiguousarray(values, dtype="<f8").tobytes()

    def float32s(self, values: tuple[float, ...]) -> None:
        """Float32 values in a row."""
        self.align(4)
        self.body += struct.pack(f"<{len(values)}f", *values)

    def boolean(self, value: bool) -> None:
        """One byte, 0 or 1."""
        self.body += b"\x01" if value else b"\x00"

    def string(self, text: str) -> None:
        """A length (with the closing NUL), the UTF-8 bytes and a NUL."""
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
    out = CdrWriter()
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


MARKER_DELETEALL = 3
"""``visualization_msgs/msg/Marker.DELETEALL``."""


@dataclass(frozen=True)
class MarkerShape:
    """One marker of a list type (``LINE_LIST``, ``TRIANGLE_LIST``, ...) at z = 0.

    Attributes:
        ns: its namespace.
        type: ``visualization_msgs/msg/Marker`` type number.
        scale: x, y, z.
        rgba: its colour.
        xy: (P, 2) its points, metres.
        id: its number within the namespace.
        text: its text (``TEXT_VIEW_FACING`` shows it; other types carry it).
    """

    ns: str
    type: int
    scale: tuple[float, float, float]
    rgba: tuple[float, float, float, float]
    xy: np.ndarray
    id: int = 0
    text: str = ""


def marker_array_bytes(
    sec: int, nanosec: int, frame_id: str, lifetime_s: float, shapes: list[MarkerShape]
) -> bytes:
    """The serialized ``MarkerArray`` of ``markers.marker_message`` (light): a DELETEALL, then
    ``shapes`` (action ADD, the identity pose, ``lifetime_s``), all stamped ``sec``,
    ``nanosec`` in ``frame_id``."""
    out = CdrWriter()
    out.uint32(1 + len(shapes))
    _marker(out, (sec, nanosec, frame_id), None, 0.0)
    for shape in shapes:
        _marker(out, (sec, nanosec, frame_id), shape, lifetime_s)
    return CDR_LE + bytes(out.body)


def _marker(
    out: CdrWriter, header: tuple[int, int, str], shape: MarkerShape | None, lifetime_s: float
) -> None:
    """One ``Marker``: ``shape``'s, or (None) a DELETEALL with every other field its default."""
    out.stamp(header[0], header[1])
    out.string(header[2])
    out.string("" if shape is None else shape.ns)
    out.int32(0 if shape is None else shape.id)
    out.int32(0 if shape is None else shape.type)
    out.int32(MARKER_DELETEALL if shape is None else 0)  # action: ADD
    out.float64s(np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]))  # pose: the identity
    out.float64s(np.zeros(3) if shape is None else np.array(shape.scale))
    out.float32s((0.0, 0.0, 0.0, 0.0) if shape is None else shape.rgba)
    out.stamp(int(lifetime_s), round((lifetime_s % 1) * 1e9))  # a Duration: sec, nanosec
    out.boolean(False)  # frame_locked
    points = np.zeros((0, 3)) if shape is None else np.zeros((len(shape.xy), 3))
    if shape is not None:
        points[:, :2] = shape.xy
    out.uint32(len(points))
    if len(points):
        out.float64s(points)
    out.uint32(0)  # colors
    out.string("")  # texture_resource
    out.stamp(0, 0)  # texture: an empty CompressedImage
    out.string("")
    out.string("")
    out.uint32(0)
    out.uint32(0)  # uv_coordinates
    out.string("" if shape is None else shape.text)  # text
    out.string("")  # mesh_resource
    out.string("")  # mesh_file: filename, data
    out.uint32(0)
    out.boolean(False)  # mesh_use_embedded_materials


class _Reader:
    """CDR primitives read from serialized bytes, aligned from the end of the encapsulation;
    a message that ends early raises ``ValueError``."""

    def __init__(self, data: bytes) -> None:
        # The last two bytes are options (XTypes puts the closing padding there): not read.
        if data[:2] != CDR_LE[:2]:
            raise ValueError("not plain little-endian CDR")
        self.body = memoryview(data)[4:]
        self.at = 0

    def take(self, fmt: str, size: int, align: int) -> tuple[Any, ...]:
        self.at += -self.at % align
        values = struct.unpack_from(fmt, self.body, self.at)
        self.at += size
        return values

    def uint32(self) -> int:
        return int(self.take("<I", 4, 4)[0])

    def string(self) -> str:
        length = self.uint32()  # the closing NUL included
        if length == 0 or self.at + length > len(self.body):
            raise ValueError("a string runs past the message")
        text = bytes(self.body[self.at : self.at + length - 1]).decode()
        self.at += length
        return text

    def skip(self, count: int, size: int, align: int) -> None:
        """Skip ``count`` items of ``size`` bytes (a sequence's elements)."""
        if count:
            self.at += -self.at % align
            self.at += count * size
            if self.at > len(self.body):
                raise ValueError("a sequence runs past the message")


@dataclass(frozen=True)
class MarkerPeople:
    """What a ``MarkerArray``'s bytes say of its people: the first marker's stamp and frame,
    and per added marker (action ADD, which MODIFY equals) its ``ns``, ``id`` and (N, 2)
    positions."""

    sec: int
    nanosec: int
    frame_id: str
    ns: list[str]
    id: list[int]
    xy: np.ndarray


def marker_array_people(data: bytes) -> MarkerPeople:
    """Read the people of a serialized ``visualization_msgs/msg/MarkerArray`` (Jazzy's layout)
    without building its Python objects, which take 7 ms at 50 markers and 12 ms at 90
    (``benchmarks/ros2_messages.py``). Markers are records of variable length (strings and
    sequences), so they are walked one by one; ``ValueError`` if the bytes end early."""
    read = _Reader(data)
    header: tuple[int, int, str] | None = None
    ns: list[str] = []
    ids: list[int] = []
    xy: list[tuple[float, float]] = []
    for _ in range(read.uint32()):
        sec, nanosec = read.take("<iI", 8, 4)
        frame_id = read.string()
        header = header or (sec, nanosec, frame_id)
        name = read.string()
        number, _kind, action = read.take("<iii", 12, 4)
        x, y = read.take("<dd", 16, 8)  # pose.position.x, y
        read.skip(1, 40, 8)  # position.z, orientation
        read.skip(1, 24, 8)  # scale
        read.skip(1, 16, 4)  # color
        read.skip(1, 8, 4)  # lifetime
        read.skip(1, 1, 1)  # frame_locked
        read.skip(read.uint32(), 24, 8)  # points
        read.skip(read.uint32(), 16, 4)  # colors
        read.string()  # texture_resource
        read.skip(1, 8, 4)  # texture: header stamp, frame, format, data
        read.string()
        read.string()
        read.skip(read.uint32(), 1, 1)
        read.skip(read.uint32(), 8, 4)  # uv_coordinates
        read.string()  # text
        read.string()  # mesh_resource
        read.string()  # mesh_file: filename, data
        read.skip(read.uint32(), 1, 1)
        read.skip(1, 1, 1)  # mesh_use_embedded_materials
        if action == 0:  # ADD (MODIFY is the same number); DELETE and DELETEALL name nobody
            ns.append(name)
            ids.append(number)
            xy.append((x, y))
    if header is None:
        raise ValueError("an empty MarkerArray")
    return MarkerPeople(*header, ns, ids, np.asarray(xy, dtype=np.float64).reshape(-1, 2))
