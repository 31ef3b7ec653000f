"""What the ROS 2 node's messages cost in Python, per message (median ms), at N people.

Usage:
    python benchmarks/ros2_messages.py [--people 50] [--repeats 200]

The forecasts of the default model for the synthetic crowd of ``benchmarks/streaming.py``:
the ``MultiDOFJointTrajectory`` built as rclpy messages (``ros2.messages.trajectory_message``)
and serialized by rclpy, against the same bytes written directly (``ros2.cdr``); a Python
subscriber's conversion of them back into messages; the incoming ``MarkerArray`` of the
tracked people, serialized by the publisher, and read by the node as Python messages against
its people read from the bytes (``ros2.messages.tracked_bytes``, what the node does); and the
markers out: the light style as message objects and as bytes (what the node publishes), the
full style as message objects, with each one's size; and the costmap of the forecasts'
90% regions (``ros2.costmap``: a 20 m x 20 m window at 0.1 m centred on the crowd, its
grid drawn and its ``OccupancyGrid`` written).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from streaming import synthetic_frames  # benchmarks/ is on sys.path


def median_ms(work: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        work()
        times.append(1000 * (time.perf_counter() - started))
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--people", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Header
    from trajectory_msgs.msg import MultiDOFJointTrajectory
    from visualization_msgs.msg import MarkerArray

    from grouptron import Predictor
    from grouptron.ros2.cdr import trajectory_bytes
    from grouptron.ros2.costmap import CostmapWindow, occupancy_grid_bytes, region_costmap
    from grouptron.ros2.markers import marker_bytes, marker_message
    from grouptron.ros2.messages import Tracked, marker_array, tracked_bytes, trajectory_message

    session = Predictor.from_checkpoint().stream()
    for k, (ids, xy) in enumerate(synthetic_frames(args.people, 20)):
        forecast = session.update(0.4 * k, [str(int(i)) for i in ids], xy)
    header = Header(frame_id="map")
    header.stamp.sec = 1_700_000_000
    names = [str(i) for i in forecast.ids]
    regions = forecast.regions(0.9)
    built = trajectory_message(forecast, header, 0.4)
    people = marker_array(Tracked(1.7e9, "map", names, np.asarray(xy)), header)
    incoming, outgoing = serialize_message(people), serialize_message(built)
    parts = {
        "trajectory built as messages": lambda: trajectory_message(forecast, header, 0.4),
        "  and serialized by rclpy": lambda: serialize_message(built),
        "trajectory written as bytes (ros2.cdr)": lambda: trajectory_bytes(
            names, forecast.point, 1_700_000_000, 0, "map", 0.4
        ),
        "trajectory read back as messages": lambda: deserialize_message(
            outgoing, MultiDOFJointTrajectory
        ),
        "MarkerArray serialized by the publisher": lambda: serialize_message(people),
        "MarkerArray read as Python messages": lambda: deserialize_message(incoming, MarkerArray),
        "its people read from the bytes (the node)": lambda: tracked_bytes(incoming),
        "light markers as messages, serialized": lambda: serialize_message(
            marker_message(forecast, header, regions, 0.4)
        ),
        "light markers as bytes (the node)": lambda: marker_bytes(
            forecast, (1_700_000_000, 0), "map", regions, 0.4
        ),
        "full markers as messages, serialized": lambda: serialize_message(
            marker_message(forecast, header, regions, 0.4, style="full")
        ),
    }
    window = CostmapWindow(size_m=20.0, resolution_m=0.1)
    corner = window.corner(forecast.point[:, 0].mean(axis=0))

    def costmap() -> bytes:
        grid = region_costmap(regions, window, corner)
        return occupancy_grid_bytes(grid, (1_700_000_000, 0), "map", corner, 0.1)

    parts["costmap, 20 m at 0.1 m (the node)"] = costmap
    light = marker_bytes(forecast, (1_700_000_000, 0), "map", regions, 0.4)
    full = serialize_message(marker_message(forecast, header, regions, 0.4, style="full"))
    print(f"{len(forecast)} people, 12 steps; median ms per message over {args.repeats}")
    for label, work in parts.items():
        print(f"{label:>42}: {median_ms(work, args.repeats):.2f}")
    print(f"markers message: light {len(light) / 1000:.1f} KB, full {len(full) / 1000:.1f} KB")


if __name__ == "__main__":
    main()
