"""The node's settings: flags of ``grouptron ros2`` and ROS parameters of the same names,
which override them (``--ros-args -p regions:=0.5`` or a parameters file)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.ros2.costmap import CostmapWindow
from grouptron.ros2.markers import MARKER_STYLES
from grouptron.ros2.messages import MARKER_ARRAY
from grouptron.ros2.qos import DEFAULT_QOS, TopicQoS


@dataclass(frozen=True)
class NodeOptions:
    """The node's settings: flags of ``grouptron ros2``, and ROS parameters of the same names
    (``fixed_frames`` a list) that override them.

    Attributes:
        topic: the tracked people's topic.
        type: its message type, ``pkg/msg/Type``.
        ros_fields: where another type holds its people (``people=PATH,id=PATH,x=..,y=..``).
        fixed_frames: frames of one's own fixed to the world (besides map, odom, world, ...).
        regions: the q of the regions drawn on the markers topic (0: none).
        namespace: of the output topics (``/grouptron/forecasts``, ``/grouptron/markers``).
        name: the node's name.
        markers: ``light``, ``full`` or ``off`` (``ros2.markers``).
        qos_input, qos_forecasts, qos_markers, qos_groups, qos_diagnostics, qos_odom,
            qos_costmap:
            overrides of each topic's QoS (``depth=N,reliability=reliable|best_effort``;
            ``ros2.qos``).
        state: a folder where the online radii and learnt weights are kept and taken up
            again after a restart (None: none).
        odom: a ``nav_msgs/msg/Odometry`` topic: people in its child frame (or, with
            ``sensor_pose``, in a sensor's frame) are put into its fixed frame
            (``ros2.odometry``); empty: none.
        sensor_pose: ``x,y,yaw`` of the sensor whose frame the people come in, on the base.
        costmap: publish ``<namespace>/costmap`` (``nav_msgs/msg/OccupancyGrid``, ``ros2.costmap``)
            at every update: the ``costmap_q``-regions of the first ``costmap_steps`` steps in
            a window of ``costmap_size_m`` at ``costmap_resolution_m``, centred on the robot
            (with odometry) or on ``costmap_centre`` (``x,y`` in the fixed frame; default 0,0).
    """

    topic: str = "/tracked_people"
    type: str = MARKER_ARRAY
    ros_fields: str | None = None
    fixed_frames: tuple[str, ...] = ()
    regions: float = 0.9
    namespace: str = "/grouptron"
    name: str = "grouptron"
    markers: str = "light"
    qos_input: str = ""
    qos_forecasts: str = ""
    qos_markers: str = ""
    qos_groups: str = ""
    qos_diagnostics: str = ""
    qos_odom: str = ""
    qos_costmap: str = ""
    state: str | None = None
    odom: str = ""
    sensor_pose: str = ""
    costmap: bool = False
    costmap_size_m: float = 20.0
    costmap_resolution_m: float = 0.1
    costmap_q: float = 0.9
    costmap_steps: int = 12
    costmap_centre: str = ""

    def qos(self, topic: str) -> TopicQoS:
        """The QoS of ``topic`` (input, forecasts, markers, diagnostics)."""
        return DEFAULT_QOS[topic].with_override(getattr(self, f"qos_{topic}"), topic)

    def costmap_window(self) -> CostmapWindow:
        """The costmap's window."""
        return CostmapWindow(self.costmap_size_m, self.costmap_resolution_m, self.costmap_steps)

    def costmap_centre_xy(self) -> np.ndarray | None:
        """(2,) the costmap's fixed centre, or None: around the robot."""
        if not self.costmap_centre:
            return None if self.odom else np.zeros(2)
        return comma_numbers(self.costmap_centre, 2, "costmap_centre must be x,y")

    def sensor_pose_xyyaw(self) -> np.ndarray | None:
        """(3,) the sensor's mounting pose on the base, or None: people come in its frame."""
        if not self.sensor_pose:
            return None
        return comma_numbers(self.sensor_pose, 3, "--sensor-pose must be x,y,yaw (m, rad)")


def comma_numbers(text: str, count: int, usage: str) -> np.ndarray:
    """(count,) finite numbers written ``a,b,...``; ``usage`` and the text in one line if
    they are not."""
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        values = np.zeros(0)
    if values.shape != (count,) or not np.isfinite(values).all():
        raise GrouptronError(f"{usage}, not {text!r}")
    return values


MAX_CELLS = 4000
"""A costmap's cells a side at most (16 million cells, 16 MB a message)."""

_CLI_ONLY = ("name", "state", "fixed_frames")
"""Options that are not ROS parameters (``fixed_frames`` is one, as a list)."""


def chosen_options(node: Any, given: NodeOptions) -> NodeOptions:
    """The options as ROS parameters of ``node`` (declared here), the flags' values their
    defaults; refused in one line where a value is not one the node takes."""
    values: dict[str, Any] = {}
    for field in dataclasses.fields(NodeOptions):
        if field.name not in _CLI_ONLY:
            default = getattr(given, field.name)
            values[field.name] = parameter(node, field.name, "" if default is None else default)
    fixed = parameter(node, "fixed_frames", list(given.fixed_frames) or [""])
    values["ros_fields"] = str(values["ros_fields"]) or None
    values["regions"] = float(values["regions"])
    chosen = dataclasses.replace(given, **values, fixed_frames=tuple(f for f in fixed if f))
    _check(chosen)
    return chosen


def _check(chosen: NodeOptions) -> None:
    """Refuse, in one line, options that cannot work together."""
    if chosen.markers not in MARKER_STYLES:
        raise GrouptronError(
            f"markers must be one of {', '.join(MARKER_STYLES)}, not {chosen.markers!r}"
        )
    for topic in DEFAULT_QOS:
        chosen.qos(topic)  # one line now, not at the first message
    if chosen.sensor_pose and not chosen.odom:
        raise GrouptronError("--sensor-pose places a sensor on the base: add --odom TOPIC")
    chosen.sensor_pose_xyyaw()  # one line now, not when the node is half made
    if chosen.costmap:
        if not 0 < chosen.costmap_q < 1 or chosen.costmap_steps < 1:
            raise GrouptronError("costmap_q must be in (0, 1) and costmap_steps at least 1")
        cells = chosen.costmap_size_m / max(chosen.costmap_resolution_m, 1e-9)
        if not 0 < chosen.costmap_resolution_m <= chosen.costmap_size_m or cells > MAX_CELLS:
            raise GrouptronError(
                "costmap_size_m / costmap_resolution_m must be 1 to "
                f"{MAX_CELLS} cells a side, not {chosen.costmap_size_m} / "
                f"{chosen.costmap_resolution_m}"
            )
        chosen.costmap_centre_xy()


def parameter(node: Any, name: str, default: Any) -> Any:
    """A ROS parameter's value (``default`` unless ``-p name:=value`` was given); a value of
    another type than the default's is one line, not rclpy's traceback."""
    from rclpy.exceptions import ParameterException

    try:
        if node.has_parameter(name):  # a lifecycle node configured again after a cleanup
            return node.get_parameter(name).value
        return node.declare_parameter(name, default).value
    except ParameterException as error:
        raise GrouptronError(f"ROS parameter {name}: {error}") from None
