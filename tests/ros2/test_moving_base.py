"""People seen from a robot driving a circle: with ``--odom`` and people in ``base_link``, the
forecasts in ``odom`` equal those made from the same people given in ``odom`` (a real rclpy
graph), and the robot's motion never becomes theirs."""

from __future__ import annotations

import random
import time
from typing import Any

import numpy as np
import pytest

from grouptron.geometry import rotation_matrix
from grouptron.inference.predictor import Predictor
from grouptron.ros2.messages import Tracked, marker_array
from grouptron.ros2.node import NodeOptions, make_node

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("nav_msgs")
pytestmark = pytest.mark.usefixtures("graph")  # rclpy on a domain of its own (conftest)

START_S = 1_700_000_000.0
RADIUS_M, SPEED_MPS = 5.0, 1.0
STANDING = np.array([[3.0, 8.0], [-4.0, 2.0]])


def robot_pose(t_s: float) -> np.ndarray:
    """(3,) x, y, yaw of a robot driving a circle at 1 m/s, counter-clockwise."""
    turn = SPEED_MPS / RADIUS_M * (t_s - START_S)
    return np.array([RADIUS_M * np.sin(turn), RADIUS_M - RADIUS_M * np.cos(turn), turn])


def people_in_odom(t_s: float) -> np.ndarray:
    """(4, 2): two standing, two walking straight at 1.2 and 1.0 m/s."""
    s = t_s - START_S
    walking = np.array([[-6.0 + 1.2 * s, -3.0], [2.0, -5.0 + 1.0 * s]])
    return np.vstack([STANDING, walking])


def _header(t_s: float, frame: str) -> Any:
    from std_msgs.msg import Header

    header = Header(frame_id=frame)
    header.stamp.sec, header.stamp.nanosec = int(t_s), round((t_s % 1) * 1e9) % 1_000_000_000
    return header


def _odometry(t_s: float) -> Any:
    from nav_msgs.msg import Odometry

    x, y, yaw = robot_pose(t_s)
    message = Odometry(header=_header(t_s, "odom"), child_frame_id="base_link")
    message.pose.pose.position.x, message.pose.pose.position.y = float(x), float(y)
    message.pose.pose.orientation.z, message.pose.pose.orientation.w = (
        np.sin(yaw / 2),
        np.cos(yaw / 2),
    )
    return message


def test_people_from_a_moving_base_are_forecast_as_in_the_fixed_frame() -> None:
    from nav_msgs.msg import Odometry
    from trajectory_msgs.msg import MultiDOFJointTrajectory
    from visualization_msgs.msg import MarkerArray

    predictor = Predictor.from_checkpoint()
    base = make_node(
        predictor,
        NodeOptions(name="gt_base", topic="/people_base", namespace="/gt_base", odom="/odom_t"),
    )
    fixed = make_node(
        predictor, NodeOptions(name="gt_fixed", topic="/people_odom", namespace="/gt_fixed")
    )
    probe = rclpy.create_node(f"robot_{random.randint(0, 10**6)}")
    odom = probe.create_publisher(Odometry, "/odom_t", 50)
    seen_base = probe.create_publisher(MarkerArray, "/people_base", 10)
    seen_fixed = probe.create_publisher(MarkerArray, "/people_odom", 10)
    got: dict[str, list[Any]] = {"base": [], "fixed": []}
    for name in got:
        probe.create_subscription(
            MultiDOFJointTrajectory, f"/gt_{name}/forecasts", got[name].append, 10
        )
    ids = [str(i) for i in range(4)]
    for k in range(16):
        t = START_S + 0.4 * k
        for step in (t - 0.2, t):  # odometry at 5 Hz, covering every stamp
            odom.publish(_odometry(step))
        pose = robot_pose(t)
        in_base = (people_in_odom(t) - pose[:2]) @ rotation_matrix(np.asarray(pose[2]))
        seen_base.publish(
            marker_array(Tracked(t, "base_link", ids, in_base), _header(t, "base_link"))
        )
        seen_fixed.publish(
            marker_array(Tracked(t, "odom", ids, people_in_odom(t)), _header(t, "odom"))
        )
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and min(len(got["base"]), len(got["fixed"])) <= k:
            for node in (base, fixed, probe):
                rclpy.spin_once(node, timeout_sec=0.005)
        assert min(len(got["base"]), len(got["fixed"])) > k, k
    last_base, last_fixed = got["base"][-1], got["fixed"][-1]
    assert last_base.header.frame_id == "odom" and len(last_base.joint_names) == 4

    def positions(message: Any) -> np.ndarray:  # (N, 12, 2)
        return np.array(
            [[[t.translation.x, t.translation.y] for t in p.transforms] for p in message.points]
        ).transpose(1, 0, 2)

    np.testing.assert_allclose(positions(last_base), positions(last_fixed), atol=0.01)
    standing = positions(last_base)[:2]
    assert np.abs(standing - STANDING[:, None]).max() < 0.05  # the robot turned; they did not
    for node in (base, fixed, probe):
        node.destroy_node()


def test_the_costmap_is_stamped_as_the_input_and_free_away_from_every_forecast() -> None:
    from nav_msgs.msg import OccupancyGrid
    from trajectory_msgs.msg import MultiDOFJointTrajectory
    from visualization_msgs.msg import MarkerArray

    forecaster = make_node(
        Predictor.from_checkpoint(),
        NodeOptions(name="gt_costmap", topic="/people_cm", namespace="/gt_cm", costmap=True),
    )
    probe = rclpy.create_node(f"planner_{random.randint(0, 10**6)}")
    people = probe.create_publisher(MarkerArray, "/people_cm", 10)
    got: dict[str, list[Any]] = {"forecasts": [], "costmap": []}
    probe.create_subscription(
        MultiDOFJointTrajectory, "/gt_cm/forecasts", got["forecasts"].append, 10
    )
    probe.create_subscription(OccupancyGrid, "/gt_cm/costmap", got["costmap"].append, 10)
    ids = [str(i) for i in range(4)]
    for k in range(10):
        t = START_S + 0.4 * k
        people.publish(marker_array(Tracked(t, "odom", ids, people_in_odom(t)), _header(t, "odom")))
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and len(got["costmap"]) <= k:
            for node in (forecaster, probe):
                rclpy.spin_once(node, timeout_sec=0.005)
        assert len(got["costmap"]) > k
    grid, last = got["costmap"][-1], got["forecasts"][-1]
    assert grid.header.frame_id == "odom" and grid.header.stamp == last.header.stamp
    assert (grid.info.width, grid.info.height) == (200, 200)
    assert grid.info.resolution == pytest.approx(0.1)
    cost = np.array(grid.data, dtype=np.int8).reshape(200, 200)
    centres = (np.arange(200) + 0.5) * 0.1
    x, y = np.meshgrid(grid.info.origin.position.x + centres, grid.info.origin.position.y + centres)
    points = np.array(
        [[t.translation.x, t.translation.y] for p in last.points for t in p.transforms]
    )  # (12 N, 2) every step's point forecast
    nearest = np.min(np.hypot(x[..., None] - points[:, 0], y[..., None] - points[:, 1]), axis=-1)
    assert (cost[nearest > 3.0] == 0).all() and (cost >= 0).all()
    first_steps = np.array([[t.translation.x, t.translation.y] for t in last.points[0].transforms])
    at = np.floor((first_steps - [grid.info.origin.position.x, grid.info.origin.position.y]) / 0.1)
    inside = (at >= 0).all(axis=1) & (at < 200).all(axis=1)
    assert inside.any() and (cost[at[inside, 1].astype(int), at[inside, 0].astype(int)] > 0).all()
    for node in (forecaster, probe):
        node.destroy_node()
