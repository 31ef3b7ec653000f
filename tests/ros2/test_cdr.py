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


@pytest.mark.parametrize("seed", range(6))
def test_people_read_from_a_marker_arrays_bytes_are_those_of_its_message(seed: int) -> None:
    """Markers with every variable-length field filled at random lengths (names, texts,
    points, colours, textures, meshes) and DELETE markers among them: every alignment."""
    from geometry_msgs.msg import Point
    from rclpy.serialization import serialize_message
    from std_msgs.msg import ColorRGBA, Header
    from visualization_msgs.msg import Marker, MarkerArray, UVCoordinate

    from grouptron.ros2.messages import MARKER_ARRAY, tracked, tracked_bytes

    rng = np.random.default_rng(seed)
    text = lambda: "x" * int(rng.integers(0, 7))  # noqa: E731
    header = Header(frame_id=text() or "map")
    header.stamp.sec, header.stamp.nanosec = 1_700_000_000 + seed, int(rng.integers(0, 10**9))
    markers = []
    for i in range(int(rng.integers(1, 9))):
        marker = Marker(header=header, ns=text(), id=i, action=int(rng.choice([0, 0, 2])))
        marker.pose.position.x, marker.pose.position.y = rng.normal(size=2).tolist()
        marker.points = [Point(x=1.0)] * int(rng.integers(0, 3))
        marker.colors = [ColorRGBA(r=0.5)] * int(rng.integers(0, 3))
        marker.texture_resource, marker.text, marker.mesh_resource = text(), text(), text()
        marker.texture.format = text()
        marker.texture.data = bytes(int(rng.integers(0, 5)))
        marker.uv_coordinates = [UVCoordinate(u=0.5)] * int(rng.integers(0, 3))
        marker.mesh_file.filename = text()
        marker.mesh_file.data = bytes(int(rng.integers(0, 4)))
        marker.frame_locked = bool(rng.integers(0, 2))
        markers.append(marker)
    message = MarkerArray(markers=markers)
    expected = tracked(message, MARKER_ARRAY)
    read = tracked_bytes(serialize_message(message))
    assert read.ids == expected.ids and read.frame_id == expected.frame_id
    assert read.time_s == expected.time_s and read.stamp == expected.stamp
    np.testing.assert_array_equal(read.xy, expected.xy)


def test_a_marker_arrays_bytes_cut_short_are_one_line() -> None:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Header

    from grouptron.errors import GrouptronError
    from grouptron.ros2.messages import Tracked, marker_array, tracked_bytes

    people = Tracked(5.0, "map", ["1", "2"], np.zeros((2, 2)))
    data = serialize_message(marker_array(people, Header(frame_id="map")))
    with pytest.raises(GrouptronError, match="does not read"):
        tracked_bytes(data[:60])
    with pytest.raises(GrouptronError, match="an empty MarkerArray"):
        tracked_bytes(data[:4] + bytes(4))
