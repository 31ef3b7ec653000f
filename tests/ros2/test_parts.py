"""The node's parts without a graph: its health and levels, the QoS overrides, and markers
a robot's network carries."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.model.regions import Regions
from grouptron.ros2.health import ERROR, OK, STALE, WARN, Health
from grouptron.ros2.qos import DEFAULT_QOS, TopicQoS


def test_health_counts_sequence_gaps_and_refusals_as_not_forecast() -> None:
    health = Health()
    for now_s, sequence in ((0.0, 1), (0.1, 2), (0.2, 5), (0.3, 1)):  # 3, 4 never came; then
        health.received_input(now_s, sequence)  # another publisher's numbering
    health.replaced()
    health.refused_input("late", "late", 0.3)
    assert health.skipped == 3 and health.not_forecast == 4
    assert health.status(0.3).values["late inputs"] == "1"


def test_health_levels_by_name() -> None:
    health = Health()
    assert health.status(0.0).level == OK
    health.received_input(0.0)
    health.published(10.0, 15.0, 20.0)
    assert health.status(0.1).level == OK  # 1.5 update times old
    health.published(10.0, 30.0, 35.0)
    assert health.status(0.2).level == WARN  # falls behind: 3 update times old
    health.refused_input("malformed", "a moving frame", 1.0)
    assert health.status(1.5).level == WARN
    status = health.status(2.1)
    assert status.level == ERROR and "a moving frame" in status.message
    health.published(10.0, 12.0, 12.0)
    assert health.status(2.2).level == OK  # refusals end with a forecast
    assert health.status(9.0).level == WARN  # silent for 9 s
    assert health.status(9.0, stopped=True).level == STALE


def test_qos_overrides_and_bad_ones() -> None:
    assert DEFAULT_QOS["input"] == TopicQoS(depth=1, reliable=True)
    chosen = DEFAULT_QOS["input"].with_override("depth=3, reliability=best_effort", "input")
    assert chosen == TopicQoS(depth=3, reliable=False)
    assert DEFAULT_QOS["markers"].with_override("", "markers") == DEFAULT_QOS["markers"]
    for bad in ("depth=0", "reliability=sometimes", "history=all"):
        with pytest.raises(GrouptronError, match="qos_input"):
            DEFAULT_QOS["input"].with_override(bad, "input")


def _forecast(people: int) -> tuple[Forecast, Regions]:
    rng = np.random.default_rng(0)
    point = np.cumsum(rng.normal(0.5, 0.1, (people, 12, 2)), axis=1) + 100.0
    forecast = Forecast(
        frame=None,
        frames=np.zeros(people, dtype=np.int64),
        ids=np.arange(people).astype(np.float64),
        point=point,
        group=np.arange(people) // 2,  # pairs: as many groups as a crowd has
    )
    regions = Regions(
        q=0.9,
        centre=point,
        major_m=np.full((people, 12), 1.5),
        minor_m=np.full((people, 12), 0.5),
        angle_rad=rng.uniform(-1.5, 1.5, (people, 12)),
    )
    return forecast, regions


def test_light_markers_at_100_people_fit_in_50_kb() -> None:
    pytest.importorskip("rclpy")
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Header

    from grouptron.ros2.markers import marker_message

    forecast, regions = _forecast(100)
    header = Header(frame_id="map")
    light = marker_message(forecast, header, regions, 0.4, now_xy=forecast.point[:, 0] - 0.5)
    full = marker_message(forecast, header, regions, 0.4, style="full")
    assert len(serialize_message(light)) <= 50_000
    assert len(serialize_message(full)) > 200_000  # what the light style saves
    by_ns = {m.ns: m for m in light.markers[1:]}
    paths, shapes, groups = by_ns["forecast"], by_ns["region"], by_ns["group"]
    assert len(paths.points) == 100 * 8  # 4 segments a person: now, 1.2 s, ..., 4.8 s
    assert (paths.points[0].x, paths.points[7].x) == (
        pytest.approx(forecast.point[0, 0, 0] - 0.5),
        pytest.approx(forecast.point[0, -1, 0]),
    )
    assert len(groups.points) == 50 * 8  # a square around each pair
    # The diamond's corners are the horizon's ellipse's axis ends.
    corners = np.array([[p.x, p.y] for p in shapes.points[:6]])
    distance = np.linalg.norm(corners - forecast.point[0, -1], axis=1)
    np.testing.assert_allclose(sorted(set(np.round(distance, 9))), [0.5, 1.5])
    empty = dataclasses.replace(forecast, ids=forecast.ids[:0], point=forecast.point[:0])
    assert len(marker_message(empty, header, None, 0.4).markers) == 1  # the DELETEALL only


@pytest.mark.parametrize("people", [0, 1, 7])
def test_light_marker_bytes_are_what_rclpy_serializes(people: int) -> None:
    pytest.importorskip("rclpy")
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Header
    from visualization_msgs.msg import MarkerArray

    from grouptron.ros2.markers import marker_bytes, marker_message

    forecast, regions = _forecast(people)
    header = Header(frame_id="odom")
    header.stamp.sec, header.stamp.nanosec = 1_700_000_123, 456_789
    for drawn in (regions, None):
        now = forecast.point[:, 0] - 0.3
        expected = marker_message(forecast, header, drawn, 0.4, now_xy=now)
        written = marker_bytes(forecast, (1_700_000_123, 456_789), "odom", drawn, 0.4, now)
        # Equal fields (colours as float32 both), and equal lengths: the bytes differ only
        # in padding, where rclpy leaves whatever was there.
        serialized = serialize_message(expected)
        read = deserialize_message(written, MarkerArray)
        assert read == deserialize_message(serialized, MarkerArray)
        assert len(written) == len(serialized)


def test_the_groups_topic_names_each_groups_members() -> None:
    pytest.importorskip("rclpy")
    from rclpy.serialization import deserialize_message
    from visualization_msgs.msg import MarkerArray

    from grouptron.ros2.markers import group_bytes

    forecast, _ = _forecast(5)
    forecast = dataclasses.replace(forecast, group=np.array([0, 2, 0, 1, 2]))
    read = deserialize_message(group_bytes(forecast, (5, 6), "map", 0.4), MarkerArray)
    assert read.markers[0].action == 3  # DELETEALL
    assert {m.id: m.text for m in read.markers[1:]} == {0: "0.0,2.0", 2: "1.0,4.0"}
    assert {m.ns for m in read.markers[1:]} == {"group"}
    for marker in read.markers[1:]:  # a closed outline around its members
        outline = np.array([[p.x, p.y] for p in marker.points])
        members = [int(float(i)) for i in marker.text.split(",")]
        centre = forecast.point[members, 0].mean(axis=0)
        assert np.allclose(outline[0], outline[-1])
        assert (np.linalg.norm(outline - centre, axis=1) > 0.5).all()
