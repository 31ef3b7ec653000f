"""The forecasts drawn for RViz and Foxglove: ``visualization_msgs/msg/MarkerArray``.

Three choices (``--markers``):

- ``light`` (the default), sized for a robot's network: a DELETEALL, then one ``LINE_LIST``
  of every person's path (namespace ``forecast``: from where they are now through every third
  step, 1.2 s apart, to the horizon), one ``TRIANGLE_LIST`` of the regions (namespace
  ``region``: per person the horizon's ellipse as the diamond of its axes' ends, two
  triangles) and one ``LINE_LIST`` of a square around each group of two or more at the
  forecast time (namespace ``group``; the groups topic has them as circles, with members).
  About 340 bytes a person and 190 a group: at most 50 KB at 100 people in 50 pairs (a test
  measures it). The node writes it from arrays (``marker_bytes``): as rclpy message objects
  it took 16 ms at 90 people.
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

PATH_EVERY_STEPS = 3
"""A light path's vertices are this many steps apart (1.2 s: forecasts bend slowly)."""


LINE_STRIP, LINE_LIST, TRIANGLE_LIST = 4, 5, 11
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
    outlines = _group_squares(forecast, now_xy)
    if len(outlines):
        shapes.append(MarkerShape("group", LINE_LIST, (0.05, 0.0, 0.0), GROUP_COLOUR, outlines))
    if regions is not None:
        diamonds = _diamonds(regions).reshape(-1, 2)
        shapes.append(
            MarkerShape("region", TRIANGLE_LIST, (1.0, 1.0, 1.0), (*COLOUR, 0.25), diamonds)
        )
    return shapes


GROUP_MARGIN_M = 0.5
"""A group's outline passes this far outside its farthest member."""
GROUP_OUTLINE_VERTICES = 16
"""The groups topic's outlines: circles of this many segments."""
GROUP_COLOUR = (0.1, 0.4, 0.9, 1.0)


def _groups(
    forecast: Forecast, now_xy: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Of every group of two or more at the forecast time: (G,) its number, (N,) which of
    them each person is in (-1: alone), (G, 2) the centre and (G,) the radius of its outline
    (``GROUP_MARGIN_M`` outside the farthest member); all groups in one pass."""
    if forecast.group is None or not len(forecast):
        return np.zeros(0, np.int64), np.full(len(forecast), -1), np.zeros((0, 2)), np.zeros(0)
    where = forecast.point[:, 0] if now_xy is None else now_xy
    labels, inverse, sizes = np.unique(forecast.group, return_inverse=True, return_counts=True)
    centre = np.stack([np.bincount(inverse, where[:, d]) / sizes for d in (0, 1)], axis=-1)
    radius = np.zeros(len(labels))
    np.maximum.at(radius, inverse, np.linalg.norm(where - centre[inverse], axis=1))
    kept = sizes >= 2
    index = np.full(len(labels), -1)
    index[kept] = np.arange(kept.sum())
    return labels[kept], index[inverse], centre[kept], radius[kept] + GROUP_MARGIN_M


def _group_squares(forecast: Forecast, now_xy: np.ndarray | None) -> np.ndarray:
    """(8 G, 2) the light markers' group outlines as one line list: a square around each
    group (its corners on the outline's circle: four segments, 192 bytes)."""
    _, _, centre, radius = _groups(forecast, now_xy)
    corners = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]])
    segments = np.stack([corners[:-1], corners[1:]], axis=1).reshape(-1, 2)  # (8, 2)
    squares: np.ndarray = centre[:, None] + radius[:, None, None] * segments  # (G, 8, 2)
    return squares.reshape(-1, 2)


def group_shapes(forecast: Forecast, now_xy: np.ndarray | None = None) -> list[MarkerShape]:
    """One closed ``LINE_STRIP`` per group of two or more people at the forecast time
    (``Forecast.group``; namespace ``group``, ``id`` the group's number, ``text`` its members'
    ids comma-separated in the forecast's order): a circle around the members' ``now_xy``
    ((N, 2); None: their first step), ``GROUP_MARGIN_M`` outside the farthest."""
    labels, member_of, centre, radius = _groups(forecast, now_xy)
    turn = np.linspace(0.0, 2 * np.pi, GROUP_OUTLINE_VERTICES + 1)  # closed: last = first
    circle = np.stack([np.cos(turn), np.sin(turn)], axis=-1)  # (V + 1, 2)
    return [  # a marker per group: its members named in its text
        MarkerShape(
            "group",
            LINE_STRIP,
            (0.05, 0.0, 0.0),
            GROUP_COLOUR,
            centre[g] + radius[g] * circle,
            id=int(labels[g]),
            text=",".join(str(i) for i in forecast.ids[member_of == g]),
        )
        for g in range(len(labels))
    ]


def group_bytes(
    forecast: Forecast,
    stamp: tuple[int, int],
    frame_id: str,
    lifetime_s: float,
    now_xy: np.ndarray | None = None,
) -> bytes:
    """The groups' MarkerArray (a DELETEALL, then :func:`group_shapes`), serialized: what the
    node publishes on ``<namespace>/groups``."""
    shapes = group_shapes(forecast, now_xy)
    return marker_array_bytes(stamp[0], stamp[1], frame_id, lifetime_s, shapes)


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
        marker = Marker(header=header, ns=shape.ns, id=shape.id, type=shape.type, lifetime=lifetime)
        marker.text = shape.text
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
