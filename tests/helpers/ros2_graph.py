"""A probe node for the ROS 2 tests: publishes tracked people, keeps what the node says."""

from __future__ import annotations

import random
import time
from typing import Any

from grouptron.ros2.messages import Tracked, marker_array


class Probe:
    """A node that publishes tracked people and keeps what the grouptron node says."""

    def __init__(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from trajectory_msgs.msg import MultiDOFJointTrajectory
        from visualization_msgs.msg import MarkerArray

        self.node = _rclpy().create_node(f"probe_{random.randint(0, 10**6)}")
        self.sent = 0
        self.publisher = self.node.create_publisher(MarkerArray, "/tracked_people", 10)
        self.got: dict[str, list[Any]] = {
            "forecasts": [],
            "markers": [],
            "groups": [],
            "diagnostics": [],
        }
        for name, kind, topic in (
            ("forecasts", MultiDOFJointTrajectory, "/grouptron/forecasts"),
            ("markers", MarkerArray, "/grouptron/markers"),
            ("groups", MarkerArray, "/grouptron/groups"),
            ("diagnostics", DiagnosticArray, "/diagnostics"),
        ):
            self.node.create_subscription(kind, topic, self.got[name].append, 10)

    def send(self, people: Tracked, forecaster: Any, wait_s: float = 5.0) -> bool:
        """Publish one message and spin both nodes until the forecaster accounted for it
        (forecast or refused: its diagnostics count every input)."""
        from std_msgs.msg import Header

        header = Header(frame_id=people.frame_id)
        header.stamp.sec, header.stamp.nanosec = (
            int(people.time_s),
            round((people.time_s % 1) * 1e9),
        )
        self.sent += 1
        self.publisher.publish(marker_array(people, header))
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline and self.accounted() < self.sent:
            _rclpy().spin_once(forecaster, timeout_sec=0.01)
            _rclpy().spin_once(self.node, timeout_sec=0.01)
        return self.accounted() >= self.sent

    def values(self) -> dict[str, str]:
        """The last diagnostics' values."""
        return {kv.key: kv.value for kv in self.got["diagnostics"][-1].status[0].values}

    def accounted(self) -> int:
        """Inputs the forecaster's last diagnostics account for (forecast or not)."""
        if not self.got["diagnostics"]:
            return 0
        values = self.values()
        return int(values["forecast inputs"]) + int(values["not forecast inputs"])


def _rclpy() -> Any:
    import rclpy

    return rclpy
