"""Messages of tracked people in, forecasts out: conversions between ROS 2 messages and the
arrays a live session takes and gives (no node, no graph here)."""

from __future__ import annotations

import importlib
import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

from grouptron.data.formats.ros_bag import KNOWN_MESSAGES, BagFields
from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.ros2.cdr import marker_array_people
from grouptron.ros2.health import Status

MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
MARKER_ADD = 0
"""``visualization_msgs/msg/Marker.ADD`` (MODIFY is the same number); DELETE and DELETEALL
markers name nobody."""


class NobodyError(GrouptronError):
    """A message that names nobody and has no stamp (an empty MarkerArray: what some trackers
    send when no one is in view): nothing to forecast, nothing wrong."""


@dataclass(frozen=True)
class Tracked:
    """The people of one message: when (seconds of its header stamp), in which frame, who
    (ids as strings, as messages name them) and where ((N, 2) metres)."""

    time_s: float
    frame_id: str
    ids: list[str]
    xy: np.ndarray
    stamp: tuple[int, int] = (0, 0)
    """The header stamp as given (sec, nanosec), for what is published in reply."""


def message_class(kind: str) -> Any:
    """The message class of ``pkg/msg/Type``, imported from the ROS environment."""
    parts = kind.split("/")
    if len(parts) != 3 or parts[1] != "msg":
        raise GrouptronError(f"--type must be PACKAGE/msg/TYPE, not {kind!r}")
    try:
        return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[2])
    except (ImportError, AttributeError):
        raise GrouptronError(
            f"message type {kind} is not installed in this ROS environment (pip install "
            f"ros-jazzy-{parts[0].replace('_', '-')}, or source its workspace)"
        ) from None


def _attribute(value: Any, path: str) -> Any:
    for name in path.split("."):
        value = getattr(value, name)
    return value


def _stamp_s(header: Any) -> float:
    return float(header.stamp.sec) + 1e-9 * float(header.stamp.nanosec)


def tracked(message: Any, kind: str, fields: BagFields | None = None) -> Tracked:
    """The people of ``message`` of type ``kind``: a MarkerArray's markers (one per person:
    its ``ns``/``id``, ``pose.position``; DELETE markers ignored), or where ``fields`` (the
    bags' ``--ros-fields`` mapping, or a known type's) says they are. Refuses, in one line, a
    message with no header, NaN positions or an id twice."""
    if kind == MARKER_ARRAY:
        shown = [m for m in message.markers if m.action == MARKER_ADD]
        if not message.markers:
            raise NobodyError("an empty MarkerArray: no stamp, nobody to forecast")
        header = message.markers[0].header
        ids = [(m.ns if m.id == 0 else f"{m.ns}/{m.id}") if m.ns else str(m.id) for m in shown]
        xy = [(m.pose.position.x, m.pose.position.y) for m in shown]
    else:
        fields = fields or KNOWN_MESSAGES.get(kind)
        if fields is None:
            raise GrouptronError(
                f"{kind}: say where its people are with --ros-fields "
                "people=PATH,id=PATH,x=PATH,y=PATH"
            )
        try:
            people = list(_attribute(message, fields.people))
            header = message.header
            ids = [str(_attribute(p, fields.id)) for p in people]
            xy = [(_attribute(p, fields.x), _attribute(p, fields.y)) for p in people]
        except AttributeError as error:
            raise GrouptronError(f"{kind}: {error}; check --ros-fields") from None
    positions = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    stamp = (int(header.stamp.sec), int(header.stamp.nanosec))
    return _checked(_stamp_s(header), str(header.frame_id), ids, positions, stamp)


def tracked_bytes(data: bytes) -> Tracked:
    """The people of a serialized MarkerArray, as :func:`tracked` reads its message, without
    building its Python objects (``cdr.marker_array_people``)."""
    if data[4:8] == bytes(4):  # no markers: the same line as tracked()'s
        raise NobodyError("an empty MarkerArray: no stamp, nobody to forecast")
    try:
        people = marker_array_people(data)
    except (ValueError, UnicodeDecodeError, struct.error) as error:
        raise GrouptronError(f"a MarkerArray that does not read: {error}") from None
    ids = [
        (ns if number == 0 else f"{ns}/{number}") if ns else str(number)
        for ns, number in zip(people.ns, people.id, strict=True)
    ]
    time_s = float(people.sec) + 1e-9 * float(people.nanosec)
    return _checked(time_s, people.frame_id, ids, people.xy, (people.sec, people.nanosec))


def _checked(
    time_s: float, frame_id: str, ids: list[str], xy: np.ndarray, stamp: tuple[int, int]
) -> Tracked:
    """The people, refused in one line where a position is not finite, an id comes twice or
    the stamp is missing."""
    if not np.isfinite(xy).all():
        raise GrouptronError("a position that is not a finite number")
    if len(set(ids)) != len(ids):
        raise GrouptronError("an id named twice in one message")
    if not math.isfinite(time_s) or time_s <= 0:
        raise GrouptronError("a message without a time stamp")
    return Tracked(time_s, frame_id, ids, xy, stamp)


def trajectory_message(forecast: Forecast, header: Any, dt_s: float) -> Any:
    """``trajectory_msgs/msg/MultiDOFJointTrajectory``: ``joint_names`` the person ids,
    ``points[k - 1]`` step k (``time_from_start`` k x ``dt_s``), ``transforms[i]`` person i's
    position."""
    from builtin_interfaces.msg import Duration
    from geometry_msgs.msg import Quaternion, Transform, Vector3
    from trajectory_msgs.msg import MultiDOFJointTrajectory, MultiDOFJointTrajectoryPoint

    still = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    points = []
    for k, step in enumerate(forecast.point.transpose(1, 0, 2).tolist()):  # (H, N, 2) floats
        seconds = (k + 1) * dt_s
        duration = Duration(sec=int(seconds), nanosec=round((seconds % 1) * 1e9))
        transforms = [
            Transform(translation=Vector3(x=x, y=y, z=0.0), rotation=still) for x, y in step
        ]
        points.append(MultiDOFJointTrajectoryPoint(transforms=transforms, time_from_start=duration))
    names = [str(i) for i in forecast.ids]
    return MultiDOFJointTrajectory(header=header, joint_names=names, points=points)


def _point(x: float, y: float) -> Any:
    from geometry_msgs.msg import Point

    return Point(x=float(x), y=float(y), z=0.0)


def diagnostics_message(header: Any, name: str, status: Status) -> Any:
    """``diagnostic_msgs/msg/DiagnosticArray`` with one status: its level, message and
    values."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    out = DiagnosticStatus(
        level=bytes([status.level]),
        name=name,
        message=status.message,
        hardware_id="grouptron",
        values=[KeyValue(key=k, value=v) for k, v in status.values.items()],
    )
    return DiagnosticArray(header=header, status=[out])


def marker_array(tracks: Tracked, header: Any) -> Any:
    """A MarkerArray of people (a sphere each, ``id`` their number): what ``--replay``
    publishes, and what the node reads."""
    from visualization_msgs.msg import Marker, MarkerArray

    out = MarkerArray()
    for name, (x, y) in zip(tracks.ids, tracks.xy, strict=True):
        number = name.isdigit() and int(name) < 2**31
        marker = Marker(
            header=header,
            ns="" if number else name,  # a name that is no number rides in the namespace
            id=int(name) if number else 0,
            type=Marker.SPHERE,
            action=MARKER_ADD,
        )
        marker.pose.position = _point(x, y)
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = marker.scale.z = 0.4
        marker.color.a = 1.0
        out.markers.append(marker)
    return out
