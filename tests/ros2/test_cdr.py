"""The forecasts serialized directly read back as the message rclpy would have built."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from grouptron.ros2.cdr import trajectory_bytes
from grouptron.ros2.messages import trajectory_message

pytest.importorskip("rclpy")


@pytest.mark.parametrize(
    ("people", "frame_id"), [(0, "map"), (1, "m"), (3, "odom_x"), (50, "map"), (7, "")]
)
def test_the_bytes_read_back_as_the_message(people: int, frame_id: str) -> None:
    """Every alignment case: names of 1-6 characters, frame ids of 0-6, no one at all."""
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Header
    from trajectory_msgs.msg import MultiDOFJointTrajectory

    rng = np.random.default_rng(people)
    ids = np.array([f"p{i}" * (i % 3 + 1) for i in range(people)], dtype=object)
    forecast = SimpleNamespace(ids=ids, point=rng.normal(size=(people, 12, 2)))
    header = Header(frame_id=frame_id)
    header.stamp.sec, header.stamp.nanosec = 1_700_000_000, 400_000_000
    expected = trajectory_message(forecast, header, 0.4)
    data = trajectory_bytes(
        [str(i) for i in ids], forecast.point, 1_700_000_000, 400_000_000, frame_id, 0.4
    )
    assert deserialize_message(data, MultiDOFJointTrajectory) == expected
    assert len(data) == len(serialize_message(expected))
