"""The quality of service of every topic the node uses, and how a user overrides it.

Defaults, and why:

- the input (tracked people): keep last 1, reliable. Only the newest message is ever
  forecast: a queue would hand the node messages it has no time for, oldest first.
- ``forecasts``, ``markers`` and ``groups``: keep last 1, reliable. A planner wants the
  newest forecast, not a backlog.
- ``/diagnostics``: keep last 10, reliable. A monitor should see every status.
- the odometry (``--odom``): keep last 50, reliable. Every pose between two messages of
  people is needed to place them.
- ``costmap`` (``--costmap``): keep last 1, reliable, transient local: a Nav2 costmap layer
  subscribes to its map topic transient local by default, which a volatile publisher does not
  serve; a transient-local one serves both kinds.

All others are volatile (no late-joiner gets an old forecast). A tracker that publishes best effort
(``SensorDataQoS``) is not heard by a reliable subscription: set ``qos_input`` to
``reliability=best_effort``. Overrides are ROS parameters ``qos_input``, ``qos_forecasts``,
``qos_markers``, ``qos_groups``, ``qos_diagnostics``, ``qos_odom`` and ``qos_costmap``
(``--ros-args -p qos_input:=depth=1,reliability=best_effort``) or the same keys of a
parameters file, each a comma-separated ``depth=N`` and/or ``reliability=reliable|best_effort``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from grouptron.errors import GrouptronError


@dataclass(frozen=True)
class TopicQoS:
    """A topic's quality of service: keep the last ``depth`` messages, reliable or best
    effort, volatile or (``transient_local``) kept for subscribers that join later."""

    depth: int = 1
    reliable: bool = True
    transient_local: bool = False

    def with_override(self, text: str, name: str) -> TopicQoS:
        """This QoS with ``text`` (``depth=N,reliability=reliable|best_effort``, either part
        optional; empty: unchanged) applied; one line if it is not that."""
        chosen = self
        for part in filter(None, (p.strip() for p in text.split(","))):
            key, _, value = part.partition("=")
            if key == "depth" and value.isdigit() and int(value) >= 1:
                chosen = replace(chosen, depth=int(value))
            elif key == "reliability" and value in ("reliable", "best_effort"):
                chosen = replace(chosen, reliable=value == "reliable")
            else:
                raise GrouptronError(
                    f"qos_{name}: {part!r} is not depth=N (N >= 1) or "
                    "reliability=reliable|best_effort"
                )
        return chosen

    def profile(self) -> Any:
        """The rclpy ``QoSProfile``."""
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=self.depth,
            reliability=ReliabilityPolicy.RELIABLE
            if self.reliable
            else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL
            if self.transient_local
            else DurabilityPolicy.VOLATILE,
        )

    def describe(self) -> str:
        """``keep last N, reliable`` (for logs and docs)."""
        return f"keep last {self.depth}, {'reliable' if self.reliable else 'best effort'}"


DEFAULT_QOS = {
    "input": TopicQoS(depth=1),
    "forecasts": TopicQoS(depth=1),
    "markers": TopicQoS(depth=1),
    "groups": TopicQoS(depth=1),
    "diagnostics": TopicQoS(depth=10),
    "odom": TopicQoS(depth=50),
    "costmap": TopicQoS(depth=1, transient_local=True),
}
"""Each topic's QoS unless a ``qos_<topic>`` parameter overrides it (module docstring)."""
