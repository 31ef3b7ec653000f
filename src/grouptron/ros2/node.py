"""The node: forecasts every message of tracked people on a live ROS 2 graph.

In: a topic of tracked people (``visualization_msgs/msg/MarkerArray`` by default, or any
installed type with a field mapping). Out, on every input: ``/grouptron/forecasts``
(``trajectory_msgs/msg/MultiDOFJointTrajectory``), ``/grouptron/markers``
(``visualization_msgs/msg/MarkerArray``: lines and region ellipses) and ``/diagnostics``.
When updates fall behind, the newest input wins and the ones it replaced are counted, never
queued without bound; a malformed message gives one warning and is skipped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grouptron.data.formats.ros_bag import BagFields, check_fixed_frame
from grouptron.errors import GrouptronError
from grouptron.inference.learning import LearningOptions
from grouptron.inference.predictor import Predictor
from grouptron.ros2.cdr import trajectory_bytes
from grouptron.ros2.messages import (
    MARKER_ARRAY,
    diagnostics_message,
    marker_message,
    message_class,
    tracked,
)


@dataclass(frozen=True)
class NodeOptions:
    """The node's settings: flags of ``grouptron ros2``, and ROS parameters of the same names
    (``fixed_frames`` a list) that override them.

    Attributes:
        topic: the tracked people's topic.
        type: its message type, ``pkg/msg/Type``.
        ros_fields: where another type holds its people (``people=PATH,id=PATH,x=..,y=..``).
        fixed_frames: frames of one's own fixed to the world (besides map, odom, world, ...).
        regions: the q of the region ellipses on the markers topic (0: none).
        namespace: of the output topics (``/grouptron/forecasts``, ``/grouptron/markers``).
        name: the node's name.
    """

    topic: str = "/tracked_people"
    type: str = MARKER_ARRAY
    ros_fields: str | None = None
    fixed_frames: tuple[str, ...] = ()
    regions: float = 0.9
    namespace: str = "/grouptron"
    name: str = "grouptron"


# One function holding the node's class: rclpy is imported only when a node is made (the
# package imports without it), and the class closes over the predictor and options.
def make_node(
    predictor: Predictor,
    options: NodeOptions,
    *,
    online: bool = False,
    learn: LearningOptions | None = None,
) -> Any:
    """The node (rclpy must be initialised); ``predictor`` forecasts, its session adapts its
    radii with ``online`` and learns the site with ``learn`` (``node.session.save_site``)."""
    from rclpy.node import Node
    from rclpy.qos import QoSProfile

    class ForecastNode(Node):
        """See the module: forecasts on every message of tracked people."""

        def __init__(self) -> None:
            super().__init__(options.name)
            chosen = self._chosen_options(options)
            self.kind = chosen.type
            self.fields = BagFields.parse(chosen.ros_fields) if chosen.ros_fields else None
            self.options = chosen
            # Online calibration and learning are ROS parameters too (flags their defaults).
            online_on = bool(_parameter(self, "online", online))
            learn_on = bool(_parameter(self, "learn", learn is not None))
            chosen_learn = (learn or LearningOptions()) if learn_on else False
            self.session = predictor.stream(online_calibration=online_on, learn=chosen_learn)
            self.dt_s = predictor.config.data.dt_s
            self.latest: Any = None
            self.counts = {"received": 0, "forecast": 0, "dropped": 0, "malformed": 0}
            self.last_update_ms = 0.0
            self.last_people = 0
            self.warned: set[str] = set()
            queue = QoSProfile(depth=10)
            incoming = message_class(chosen.type)
            self.create_subscription(incoming, chosen.topic, self._received, queue)
            out = chosen.namespace.rstrip("/")
            self.forecasts = self.create_publisher(
                message_class("trajectory_msgs/msg/MultiDOFJointTrajectory"),
                f"{out}/forecasts",
                queue,
            )
            self.markers = self.create_publisher(
                message_class("visualization_msgs/msg/MarkerArray"), f"{out}/markers", queue
            )
            self.diagnostics = self.create_publisher(
                message_class("diagnostic_msgs/msg/DiagnosticArray"), "/diagnostics", queue
            )
            # Processing waits on a guard condition the subscription triggers: the executor
            # takes every message waiting first, so the newest is the one forecast.
            self.ready = self.create_guard_condition(self._process)

        def _received(self, message: Any) -> None:
            self.counts["received"] += 1
            if self.latest is not None:  # the newest input wins
                self.counts["dropped"] += 1
            self.latest = message
            self.ready.trigger()

        def _process(self) -> None:
            message, self.latest = self.latest, None
            if message is None:
                return
            try:
                people = tracked(message, self.kind, self.fields)
                fixed = self.options.fixed_frames
                check_fixed_frame(Path(self.options.topic), people.frame_id, fixed)
                started = time.perf_counter()
                forecast = self.session.update(people.time_s, people.ids, people.xy)
            except GrouptronError as error:
                self.counts["malformed"] += 1
                self._warn_once(str(error))
                return
            regions = (
                forecast.regions(options.regions) if options.regions and len(forecast) else None
            )
            self.last_update_ms = 1000 * (time.perf_counter() - started)
            self.last_people = len(people.ids)
            self.counts["forecast"] += 1
            header = _header_of(message, self.kind)
            stamp = header.stamp
            self.forecasts.publish(  # serialized here: 600 transform objects cost 3 ms
                trajectory_bytes(
                    [str(i) for i in forecast.ids],
                    forecast.point,
                    stamp.sec,
                    stamp.nanosec,
                    header.frame_id,
                    self.dt_s,
                )
            )
            self.markers.publish(marker_message(forecast, header, regions, self.dt_s))
            self.diagnostics.publish(self._diagnostics(header))

        def _diagnostics(self, header: Any) -> Any:
            online_state = self.session.online
            calibrated = "shipped or given" if predictor.calibration is not None else "none"
            values = {
                "update time ms": f"{self.last_update_ms:.1f}",
                "people": str(self.last_people),
                **{f"{k} inputs": str(v) for k, v in self.counts.items()},
                "calibration": "online" if online_state is not None else calibrated,
                "learning": "off"
                if self.session.learning is None
                else self.session.learning.line(),
            }
            level = 0 if not self.counts["malformed"] else 1
            return diagnostics_message(header, "grouptron forecasts", values, level)

        def _warn_once(self, text: str) -> None:
            kind = text.split(":")[0]
            if kind not in self.warned:
                self.warned.add(kind)
                self.get_logger().warning(f"skipped a message of {self.options.topic}: {text}")

        def _chosen_options(self, given: NodeOptions) -> NodeOptions:
            """The options as ROS parameters (``--ros-args -p regions:=0.5``), the flags'
            values their defaults."""
            values = {}
            for name in ("topic", "type", "ros_fields", "regions", "namespace"):
                default = getattr(given, name)
                default = "" if default is None else default
                values[name] = _parameter(self, name, default)
            fixed = _parameter(self, "fixed_frames", list(given.fixed_frames) or [""])
            return NodeOptions(
                topic=str(values["topic"]),
                type=str(values["type"]),
                ros_fields=str(values["ros_fields"]) or None,
                fixed_frames=tuple(f for f in fixed if f),
                regions=float(values["regions"]),
                namespace=str(values["namespace"]),
                name=given.name,
            )

    return ForecastNode()


def _parameter(node: Any, name: str, default: Any) -> Any:
    """A ROS parameter's value (``default`` unless ``-p name:=value`` was given); a value of
    another type than the default's is one line, not rclpy's traceback."""
    from rclpy.exceptions import ParameterException

    try:
        return node.declare_parameter(name, default).value
    except ParameterException as error:
        raise GrouptronError(f"ROS parameter {name}: {error}") from None


def _header_of(message: Any, kind: str) -> Any:
    """The input's header (a MarkerArray's: its first marker's)."""
    return message.markers[0].header if kind == MARKER_ARRAY else message.header
