"""The forecasts drawn for RViz and Foxglove: ``visualization_msgs/msg/MarkerArray``.

Three choices (``--markers``):

- ``light`` (the default), sized for a robot's network: a DELETEALL, then one ``LINE_LIST``
  of every person's path (namespace ``forecast``: from where they are now through every second
  step, 0.8 s apart, to the horizon) and one ``TRIANGLE_LIST`` of the regions (namespace
  ``region``: per person the horizon's ellipse as the diamond of its axes' ends, two
  triangles). About 430 bytes a person: at most 50 KB at 100 people (a test measures it).
  The node writes it from arrays (``marker_bytes``): as rclpy message objects it took 16 ms
  at 90 people.
- ``full``: a DELETEALL, a ``LINE_STRIP`` per person through every step and a flat cylinder per
  person and step for its region: exact ellipses, about 3 KB a person (265 KB at 95 people),
  built as message objects (over 100 ms at 90 people): for a desktop, not a robot.
- ``off``: no markers topic.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grouptron.inference.forecast import Forecast
from grouptron.model.regions import Regions
from grouptron.ros2.cdr import MarkerShape, marker_array_bytes

MARKER_STYLES = ("light", "full", "off")
"""The ``--markers`` choices."""

PATH_EVERY_STEPS = 2
"""A light path's vertices are this many steps apart (0.8 s: forecasts bend slowly)."""


LINE_LIST, TRIANGLE_LIST = 5, 11
"""``visualization_msgs/msg/Marker`` types."""
COLOUR = (0.9, 0.3, 0.1)


def light_shapes(
    forecast: Forecast, regions: Regions | None, now_xy: np.ndarray | None = None
) -> list[MarkerShape]:
    """The light style's markers: the paths' line list and (with ``regions``) the horizon's
    diamonds; ``now_xy`` (N, 2): where each person is now, the start of their path (None:
    their first step). Nothing when nobody was forecast."""
    if not len(forecast):
        return []
    start = forecast.point[:, 0] if now_xy is None else now_xy
    # (N, V, 2): now, then every PATH_EVERY_STEPS steps up to the horizon.
    vertices = np.concatenate(
        [start[:, None], forecast.point[:, PATH_EVERY_STEPS - 1 :: PATH_EVERY_STEPS]], axis=1
    )
    segments = np.stack([vertices[:, :-1], vertices[:, 1:]], axis=2)  # (N, V - 1, 2, 2)
    shapes = [
        MarkerShape(
            "forecast", LINE_LIST, (0.05, 0.0, 0.0), (*COLOUR, 1.0), segments.reshape(-1, 2)
        )
    ]
    if regions is not None:
        diamonds = _diamonds(regions).reshape(-1, 2)
        shapes.append(
            MarkerShape("region", TRIANGLE_LIST, (1.0, 1.0, 1.0), (*COLOUR, 0.25), diamonds)
        )
    return shapes


def marker_bytes(
    forecast: Forecast,
    stamp: tuple[int, int],
    frame_id: str,
    regions: Regions | None,
    lifetime_s: float,
    now_xy: np.ndarray | None = None,
) -> bytes:
    """The light style's MarkerArray, serialized (what the node publishes: the same bytes as
    ``marker_message``'s, written from arrays)."""
    shapes = light_shapes(forecast, regions, now_xy)
    return marker_array_bytes(stamp[0], stamp[1], frame_id, lifetime_s, shapes)


def marker_message(
    forecast: Forecast,
    header: Any,
    regions: Regions | None,
    lifetime_s: float,
    *,
    style: str = "light",
    now_xy: np.ndarray | None = None,
) -> Any:
    """The MarkerArray of ``forecast`` in ``style`` (``light`` or ``full``) as rclpy message
    objects, stamped and framed by ``header``; ``now_xy`` as for :func:`light_shapes`."""
    if style == "full":
        return _full(forecast, header, regions, lifetime_s)
    from visualization_msgs.msg import Marker, MarkerArray

    lifetime = _duration(lifetime_s)
    out = MarkerArray(markers=[Marker(header=header, action=Marker.DELETEALL)])
    for shape in light_shapes(forecast, regions, now_xy):
        marker = Marker(header=header, ns=shape.ns, id=0, type=shape.type, lifetime=lifetime)
        marker.scale.x, marker.scale.y, marker.scale.z = shape.scale
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = shape.rgba
        marker.pose.orientation.w = 1.0
        marker.points = _points(shape.xy)
        out.markers.append(marker)
    return out


def _diamonds(regions: Regions) -> np.ndarray:
    """(N, 6, 2) two triangles per person: the horizon's ellipse as the diamond of its axes'
    ends (major ends a, b; minor ends c, d: triangles a c b and a b d)."""
    centre = regions.centre[:, -1]  # (N, 2)
    angle = regions.angle_rad[:, -1]
    along = np.stack([np.cos(angle), np.sin(angle)], axis=-1)  # (N, 2) the major axis
    across = np.stack([-along[:, 1], along[:, 0]], axis=-1)
    major = along * regions.major_m[:, -1, None]
    minor = across * regions.minor_m[:, -1, None]
    a, b, c, d = centre + major, centre - major, centre + minor, centre - minor
    return np.stack([a, c, b, a, b, d], axis=1)


def _points(xy: np.ndarray) -> list[Any]:
    from geometry_msgs.msg import Point

    return [Point(x=x, y=y, z=0.0) for x, y in xy.tolist()]


def _duration(seconds: float) -> Any:
    from builtin_interfaces.msg import Duration

    return Duration(sec=int(seconds), nanosec=round((seconds % 1) * 1e9))


def _full(forecast: Forecast, header: Any, regions: Regions | None, lifetime_s: float) -> Any:
    """The ``full`` style: a line strip per person, a flat cylinder per person and step."""
    from geometry_msgs.msg import Point
    from visualization_msgs.msg import Marker, MarkerArray

    lifetime = _duration(lifetime_s)
    out = MarkerArray(markers=[Marker(header=header, action=Marker.DELETEALL)])
    for i, person in enumerate(forecast.ids):
        line = Marker(header=header, ns="forecast", id=i, type=Marker.LINE_STRIP, lifetime=lifetime)
        line.scale.x = 0.05
        line.color.r, line.color.g, line.color.b, line.color.a = 0.9, 0.3, 0.1, 1.0
        line.text = str(person)
        line.points = _points(forecast.point[i])
        out.markers.append(line)
        if regions is None:
            continue
        for k in range(regions.major_m.shape[1]):
            ellipse = Marker(
                header=header, ns="region", id=i * 100 + k, type=Marker.CYLINDER, lifetime=lifetime
            )
            x, y = regions.centre[i, k]
            ellipse.pose.position = Point(x=float(x), y=float(y), z=0.0)
            half = 0.5 * float(regions.angle_rad[i, k])
            ellipse.pose.orientation.z, ellipse.pose.orientation.w = math.sin(half), math.cos(half)
            ellipse.scale.x = 2 * float(regions.major_m[i, k])
            ellipse.scale.y = 2 * float(regions.minor_m[i, k])
            ellipse.scale.z = 0.01
            ellipse.color.r, ellipse.color.g, ellipse.color.b, ellipse.color.a = 0.9, 0.3, 0.1, 0.15
            out.markers.append(ellipse)
    return out
