"""The node: forecasts the newest message of tracked people on a live ROS 2 graph.

In: a topic of tracked people (``visualization_msgs/msg/MarkerArray`` by default, or any
installed type with a field mapping). Out, on every input forecast: ``/grouptron/forecasts``
(``trajectory_msgs/msg/MultiDOFJointTrajectory``) and ``/grouptron/markers``
(``visualization_msgs/msg/MarkerArray``, ``ros2.markers``); ``/diagnostics`` after every
input and once a second (``ros2.health``). Only the newest input is forecast, never a backlog
(the input keeps the last message only, ``ros2.qos``); the ones it replaced, and those refused,
are counted. The work between a message and what leaves is ``ros2.live`` (no graph).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from grouptron.data.formats.ros_bag import BagFields
from grouptron.errors import GrouptronError
from grouptron.geometry import yaw_of_quaternion
from grouptron.inference.learning import LearningOptions
from grouptron.inference.predictor import Predictor
from grouptron.ros2.cdr import trajectory_bytes
from grouptron.ros2.costmap import occupancy_grid_bytes, region_costmap
from grouptron.ros2.live import LiveForecaster, Made
from grouptron.ros2.markers import group_bytes, marker_bytes, marker_message
from grouptron.ros2.messages import (
    MARKER_ARRAY,
    NobodyError,
    Tracked,
    diagnostics_message,
    message_class,
    tracked,
    tracked_bytes,
)
from grouptron.ros2.odometry import WAIT_S as ODOMETRY_WAIT_S
from grouptron.ros2.odometry import OdometryTrack, Placement
from grouptron.ros2.options import NodeOptions, chosen_options, parameter

DIAGNOSTICS_PERIOD_S = 1.0
"""``/diagnostics`` also leaves this often without input, so that a silent or refusing node is
seen."""
ODOMETRY = "nav_msgs/msg/Odometry"
"""The type of ``--odom``."""
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
"""The type of ``--costmap``'s topic."""
STOP_ACK_S = 0.2
"""How long a stopping node waits for its last status to be received."""
STATE_PERIOD_S = 10.0
"""With a state folder, the online radii (and learnt weights, when a round changed them) are
kept this often, and when the node stops."""


class NodeParts:
    """The forecasting node's behaviour, mixed into an rclpy ``Node`` by :func:`make_node`
    (rclpy is imported only when a node is made: the package imports without it)."""

    def setup(
        self,
        predictor: Predictor,
        options: NodeOptions,
        online: bool,
        learn: LearningOptions | None,
    ) -> None:
        """Parameters, session, topics and timers (after ``Node.__init__``, or a lifecycle
        node's configure)."""
        node: Any = self  # an rclpy Node too
        before = _entities(node)
        try:
            self._setup(node, predictor, options, online, learn)
        except Exception:
            for kind, entity in _entities(node) - before:  # nothing half made stays
                getattr(node, f"destroy_{kind}")(entity)
            if hasattr(self, "session"):
                self.session.close(drop_round=True)
            raise
        self._created = _entities(node) - before

    def _setup(
        self,
        node: Any,
        predictor: Predictor,
        options: NodeOptions,
        online: bool,
        learn: LearningOptions | None,
    ) -> None:
        """``setup``'s work: what a failure undoes."""
        self.active = True  # a lifecycle node's until activated: False
        chosen = chosen_options(node, options)
        self.fields = BagFields.parse(chosen.ros_fields) if chosen.ros_fields else None
        self.options = chosen
        # Online calibration and learning are ROS parameters too (flags their defaults).
        online_on = bool(parameter(node, "online", online))
        learn_on = bool(parameter(node, "learn", learn is not None))
        chosen_learn = (learn or LearningOptions()) if learn_on else False
        self.session = predictor.stream(
            online_calibration=online_on, learn=chosen_learn, state=chosen.state
        )
        self.odometry: OdometryTrack | None = (
            OdometryTrack(chosen.sensor_pose_xyyaw()) if chosen.odom else None
        )
        self.live = LiveForecaster(
            self.session,
            chosen.topic,
            chosen.fixed_frames,
            chosen.regions,
            odometry=self.odometry,
        )
        self.predictor = predictor
        self.dt_s = predictor.config.data.dt_s
        self.latest: tuple[Any, int] | None = None
        # A message waiting for odometry: (message, arrival ns, since when, monotonic s).
        self.waiting: tuple[Any, int, float] | None = None
        self.warned: set[str] = set()
        self.stopped = False
        self._kept: tuple[int, int] | None = None  # the learning (rounds, accepted) last kept
        self.costmap_ms: float | None = None
        self._make_topics(node, chosen)

    def _make_topics(self, node: Any, chosen: NodeOptions) -> None:
        """The subscriptions, publishers, timers and guard condition of ``setup``."""
        out = chosen.namespace.rstrip("/")
        # A MarkerArray is read from its bytes (ros2.cdr): its Python objects cost 7 ms at 50.
        self.raw = chosen.type == MARKER_ARRAY
        node.create_subscription(
            message_class(chosen.type),
            chosen.topic,
            self._received,
            chosen.qos("input").profile(),
            raw=self.raw,
        )
        self.forecasts = node.create_publisher(
            message_class("trajectory_msgs/msg/MultiDOFJointTrajectory"),
            f"{out}/forecasts",
            chosen.qos("forecasts").profile(),
        )
        self.markers = None
        if chosen.markers != "off":
            self.markers = node.create_publisher(
                message_class(MARKER_ARRAY), f"{out}/markers", chosen.qos("markers").profile()
            )
        self.diagnostics = node.create_publisher(
            message_class("diagnostic_msgs/msg/DiagnosticArray"),
            "/diagnostics",
            chosen.qos("diagnostics").profile(),
        )
        # Processing waits on a guard condition the subscription triggers: the executor
        # takes every message waiting first, so the newest is the one forecast.
        self.ready = node.create_guard_condition(self._process)
        self.groups = node.create_publisher(
            message_class(MARKER_ARRAY), f"{out}/groups", chosen.qos("groups").profile()
        )
        self.costmap = None
        if chosen.costmap:
            self.costmap = node.create_publisher(
                message_class(OCCUPANCY_GRID), f"{out}/costmap", chosen.qos("costmap").profile()
            )
        node.create_timer(DIAGNOSTICS_PERIOD_S, self._say)
        if self.odometry is not None:
            node.create_subscription(
                message_class(ODOMETRY), chosen.odom, self._odometry, chosen.qos("odom").profile()
            )
            node.create_timer(ODOMETRY_WAIT_S / 2, self._retry_waiting)
        if chosen.state:
            node.create_timer(STATE_PERIOD_S, self._keep_state)

    def teardown(self) -> None:
        """Undo ``setup``: the node's topics and timers destroyed, its session closed (a
        lifecycle node's cleanup)."""
        node = self._node()
        for kind, entity in self._created:
            getattr(node, f"destroy_{kind}")(entity)
        self._created = set()
        self.session.close(drop_round=True)

    def _received(self, message: Any, info: Any) -> None:
        health = self.live.health
        health.received_input(time.monotonic(), info.get("publication_sequence_number"))
        if self.latest is not None or self.waiting is not None:  # the newest input wins
            health.replaced()
        self.waiting = None
        arrived_ns = info.get("received_timestamp") or time.time_ns()
        self.latest = (message, int(arrived_ns))
        self.ready.trigger()

    def _process(self) -> None:
        latest, self.latest = self.latest, None
        if latest is None or self.stopped:
            return
        if not self.active:  # a lifecycle node's inputs while inactive: counted, not forecast
            self.live.health.set_aside("inactive")
            return
        message, arrived_ns = latest
        try:
            people = (
                tracked_bytes(message)
                if self.raw
                else tracked(message, self.options.type, self.fields)
            )
        except NobodyError:
            self.live.health.set_aside("empty")  # nobody in view: nothing wrong
            self._say()
            return
        except GrouptronError as error:
            self.live.refused("malformed", str(error))
            self._warn_once("malformed", str(error))
            self._say()
            return
        made = self.live.forecast(people)
        if made is Placement.WAIT:
            self._wait_for_odometry(message, arrived_ns)
            return
        self.waiting = None
        if made is None:
            self._warn_once(self.live.health.last_kind, self.live.health.last_refusal)
        else:
            self._publish(made, people, arrived_ns)
        self._say()

    def _wait_for_odometry(self, message: Any, arrived_ns: int) -> None:
        """Keep a message stamped after the newest odometry until odometry reaches it, or
        refuse it after ``odometry.WAIT_S``."""
        since = self.waiting[2] if self.waiting is not None else time.monotonic()
        if time.monotonic() - since > ODOMETRY_WAIT_S:
            self.waiting = None
            reason = f"no odometry: none reached its stamp within {ODOMETRY_WAIT_S} s"
            self.live.refused("no odometry", reason)
            self._warn_once("no odometry", reason)
            self._say()
            return
        self.waiting = (message, arrived_ns, since)

    def _odometry(self, message: Any) -> None:
        """An odometry message: the base's pose at its stamp; a waiting message is tried
        again."""
        pose = message.pose.pose
        yaw = yaw_of_quaternion(
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w
        )
        stamp = message.header.stamp
        t_s = float(stamp.sec) + 1e-9 * float(stamp.nanosec)
        xyyaw = np.array([pose.position.x, pose.position.y, yaw])
        assert self.odometry is not None  # subscribed only with one
        self.odometry.add(t_s, xyyaw, message.header.frame_id, message.child_frame_id)
        self._retry_waiting()

    def _retry_waiting(self) -> None:
        """Hand a waiting message to processing again (odometry came, or its wait is up)."""
        if self.waiting is not None and self.latest is None:
            self.latest = (self.waiting[0], self.waiting[1])
            self.ready.trigger()

    def _publish(self, made: Made, people: Tracked, arrived_ns: int) -> None:
        """The forecast, then its markers, stamped as the input and in its frame (the
        odometry's for people seen from a moving base)."""
        sec, nanosec = people.stamp
        self.forecasts.publish(  # serialized here: 600 transform objects cost 3 ms
            trajectory_bytes(
                [str(i) for i in made.forecast.ids],
                made.forecast.point,
                sec,
                nanosec,
                made.frame_id,
                self.dt_s,
            )
        )
        if self.markers is not None and self.options.markers == "light":
            self.markers.publish(  # serialized here: as message objects 16 ms at 90 people
                marker_bytes(
                    made.forecast,
                    people.stamp,
                    made.frame_id,
                    made.regions,
                    self.dt_s,
                    made.now_xy,
                )
            )
        elif self.markers is not None:
            from std_msgs.msg import Header

            header = Header(frame_id=made.frame_id)
            header.stamp.sec, header.stamp.nanosec = sec, nanosec
            self.markers.publish(
                marker_message(made.forecast, header, made.regions, self.dt_s, style="full")
            )
        self.groups.publish(  # who walks with whom at the forecast time
            group_bytes(made.forecast, people.stamp, made.frame_id, self.dt_s, made.now_xy)
        )
        if self.costmap is not None:
            self._publish_costmap(made, people)
        self.live.health.published(
            made.update_ms,
            (time.time_ns() - arrived_ns) / 1e6,
            (self._node().get_clock().now().nanoseconds - (sec * 1_000_000_000 + nanosec)) / 1e6,
        )

    def _publish_costmap(self, made: Made, people: Tracked) -> None:
        """The forecasts' regions as an OccupancyGrid around the robot (or a fixed centre)."""
        started = time.perf_counter()
        options = self.options
        centre = options.costmap_centre_xy()
        if centre is None:  # around the robot: where the odometry has it at the stamp
            assert self.odometry is not None
            centre = self.odometry.position_at(people.time_s)
        window = options.costmap_window()
        corner = window.corner(centre)
        q = options.costmap_q
        regions = made.regions if made.regions is not None and made.regions.q == q else None
        if regions is None and len(made.forecast):
            regions = made.forecast.regions(q)
        grid = (
            region_costmap(regions, window, corner)
            if regions is not None
            else np.zeros((window.cells, window.cells), dtype=np.int8)
        )
        assert self.costmap is not None
        self.costmap.publish(
            occupancy_grid_bytes(grid, people.stamp, made.frame_id, corner, window.resolution_m)
        )
        self.costmap_ms = 1000 * (time.perf_counter() - started)

    def _say(self, stopped: bool = False) -> None:
        """Publish the status (after an input, once a second, and when stopping); an
        inactive lifecycle node publishes nothing."""
        from std_msgs.msg import Header

        if not self.active and not stopped:
            return
        status = self.live.health.status(time.monotonic(), stopped=stopped)
        online_state = self.session.online
        calibrated = "shipped or given" if self.predictor.calibration is not None else "none"
        values = {
            **status.values,
            **self.live.faults(),
            "calibration": "online" if online_state is not None else calibrated,
            "threads": str(self.predictor.threads or "PyTorch's"),
            "costmap time ms": "" if self.costmap_ms is None else f"{self.costmap_ms:.1f}",
        }
        header = Header(stamp=self._node().get_clock().now().to_msg())
        said = type(status)(status.level, status.message, values)
        self.diagnostics.publish(diagnostics_message(header, "grouptron forecasts", said))

    def _keep_state(self, final: bool = False) -> None:
        """Keep the online radii, and the learnt weights when a round changed them (every
        ``STATE_PERIOD_S`` and when stopping); a state that cannot be written is a warning,
        never the end of forecasting."""
        if not self.options.state:
            return
        learning = self.session.learning
        kept = None if learning is None else (learning.rounds, learning.accepted)
        site = kept is not None and (final or kept != self._kept)
        try:
            self.session.save_state(self.options.state, site=site)
        except (OSError, GrouptronError) as error:
            self._node().get_logger().warning(f"could not keep the state: {error}")
            return
        if site:
            self._kept = kept

    def stop(self) -> None:
        """Say on ``/diagnostics`` that the node stopped, keep its state, close its
        session (its learning process included); once."""
        if self.stopped:
            return
        self.stopped = True
        self._say(stopped=True)
        from rclpy.duration import Duration

        # The last status reaches its subscribers before the process ends.
        self.diagnostics.wait_for_all_acked(Duration(seconds=STOP_ACK_S))
        try:
            self._keep_state(final=True)
        finally:
            self.session.close(drop_round=True)

    def _warn_once(self, kind: str, text: str) -> None:
        """One warning per kind of refusal (``late``, ``no odometry``, or for anything
        malformed its reason without numbers), then only the counts."""
        if kind == "malformed":
            kind = re.sub(r"[-+\d.e]+", "#", text.split(":")[0])[:80]
        if kind not in self.warned:
            self.warned.add(kind)
            self._node().get_logger().warning(f"skipped a message of {self.options.topic}: {text}")

    def _node(self) -> Any:
        """This object as the rclpy Node it is mixed into."""
        return self


def make_node(
    predictor: Predictor | Callable[[], Predictor],
    options: NodeOptions,
    *,
    online: bool = False,
    learn: LearningOptions | None = None,
    lifecycle: bool = False,
) -> Any:
    """The node (rclpy must be initialised); ``predictor`` forecasts (or, a function, loads
    the one that does), its session adapts its radii with ``online`` and learns the site with
    ``learn`` (``node.session.save_site``). ``node.stop()`` says on ``/diagnostics`` that it
    stopped, keeps its state and closes the session.

    With ``lifecycle``, a ROS 2 lifecycle node (``lifecycle_msgs`` services): configure loads
    the model and makes the topics, activate starts forecasting and publishing, deactivate
    stops both (an inactive node publishes nothing), cleanup frees the model and topics."""
    if lifecycle:
        from grouptron.ros2.lifecycle import lifecycle_node  # it builds on this module

        return lifecycle_node(predictor, options, online=online, learn=learn)
    from rclpy.node import Node

    class ForecastNode(NodeParts, Node):
        """See the module: forecasts the newest message of tracked people."""

        def __init__(self) -> None:
            Node.__init__(self, options.name)
            self.setup(loaded(predictor), options, online, learn)

    return ForecastNode()


def loaded(predictor: Predictor | Callable[[], Predictor]) -> Predictor:
    """The predictor, loaded now if given as a function that loads it."""
    return predictor if isinstance(predictor, Predictor) else predictor()


def _entities(node: Any) -> set[tuple[str, Any]]:
    """The node's topics, timers and guard conditions, by the kind ``destroy_<kind>`` takes."""
    return {
        *(("subscription", s) for s in node.subscriptions),
        *(("publisher", p) for p in node.publishers),
        *(("timer", t) for t in node.timers),
        *(("guard_condition", g) for g in node.guards),
    }
