"""A bag's people published on a live graph at their recorded rate, as MarkerArray messages
(``grouptron ros2 --replay run.mcap --topic /people``): the node demonstrated without a robot."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.data.formats.ros_bag import BagFields, read_bag
from grouptron.ros2.messages import Tracked, marker_array


def replay_bag(
    node: Any,
    path: Path,
    topic: str,
    out_topic: str,
    fields: BagFields | None = None,
    *,
    speed: float = 1.0,
) -> int:
    """Publish every message of ``topic`` in ``path`` on ``out_topic`` at its recorded rate
    (``speed`` times faster), stamped as recorded; returns how many were published."""
    from std_msgs.msg import Header
    from visualization_msgs.msg import MarkerArray

    bag = read_bag(path, topic, fields)
    publisher = node.create_publisher(MarkerArray, out_topic, 10)
    started, first = time.monotonic(), float(bag.time_s.min())
    published = 0
    for number in np.unique(bag.message):
        rows = bag.message == number
        t = float(bag.time_s[rows][0])
        wait = (t - first) / speed - (time.monotonic() - started)
        if wait > 0:
            time.sleep(wait)
        header = Header(frame_id=bag.frame_id)
        header.stamp.sec, header.stamp.nanosec = int(t), round((t % 1) * 1e9) % 1_000_000_000
        names = [bag.name(i) for i in bag.ped_id[rows]]
        people = Tracked(t, bag.frame_id, names, bag.pos_m[rows])
        publisher.publish(marker_array(people, header))
        published += 1
    return published
