"""The forecasts drawn for RViz and Foxglove: ``visualization_msgs/msg/MarkerArray``.

Three choices (``--markers``):

- ``light`` (the default), sized for a robot's network: a DELETEALL, then one ``LINE_LIST``
  of every person's path (namespace ``forecast``: from where they are now through every second
  step, 0.8 s apart, to the horizon) and one ``TRIANGLE_LIST`` of the regions (namespace
  ``region``: per person the horizon's ellipse as the diamond of its axes' ends, two
  triangles). About 430 bytes a person: at most 50 KB at 100 people (a test measures it).
- ``full``: a DELETEALL, a ``LINE_STRIP`` per person through every step and a flat cylinder per
  person and step for its region: exact ellipses, about 2.8 KB a person (265 KB at 95 people).
- ``off``: no markers topic.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grouptron.inference.forecast import Forecast
from grouptron.model.regions import Regions

MARKER_STYLES = ("light", "full", "off")
"""The ``--markers`` choices."""

PATH_EVERY_STEPS = 2
"""A light path's vertices are this many steps apart (0.8 s: forecasts bend slowly)."""


def marker_message(
    forecast: Forecast,
    header: Any,
    regions: Regions | None,
    lifetime_s: float,
    *,
    style: str = "light",
    now_xy: np.ndarray | None = None,
) -> Any:
    """The MarkerArray of ``forecast`` in ``style`` (``light`` or ``full``), stamped and
    framed by ``header``; ``now_xy`` (N, 2): where each person is now, the start of a light
    path (None: its first step)."""
    if style == "full":
        return _full(forecast, header, regions, lifetime_s)
    from visualization_msgs.msg import Marker, MarkerArray

    lifetime = _duration(lifetime_s)
    out = MarkerArray(markers=[Marker(header=header, action=Marker.DELETEALL)])
    if not len(forecast):
        return out
    start = forecast.point[:, 0] if now_xy is None else now_xy
    # (N, V, 2): now, then every PATH_EVERY_STEPS steps up to the horizon.
    vertices = np.concatenate(
        [start[:, None], forecast.point[:, PATH_EVERY_STEPS - 1 :: PATH_EVERY_STEPS]], axis=1
    )
    segments = np.stack([vertices[:, :-1], vertices[:, 1:]], axis=2)  # (N, V - 1, 2, 2)
    paths = Marker(header=header, ns="forecast", id=0, type=Marker.LINE_LIST, lifetime=lifetime)
    paths.scale.x = 0.05
    paths.color.r, paths.color.g, paths.color.b, paths.color.a = 0.9, 0.3, 0.1, 1.0
    paths.pose.orientation.w = 1.0
    paths.points = _points(segments.reshape(-1, 2))
    out.markers.append(paths)
    if regions is not None:
        shapes = Marker(
            header=header, ns="region", id=0, type=Marker.TRIANGLE_LIST, lifetime=lifetime
        )
        shapes.scale.x = shapes.scale.y = shapes.scale.z = 1.0
        shapes.color.r, shapes.color.g, shapes.color.b, shapes.color.a = 0.9, 0.3, 0.1, 0.25
        shapes.pose.orientation.w = 1.0
        shapes.points = _points(_diamonds(regions).reshape(-1, 2))
        out.markers.append(shapes)
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
