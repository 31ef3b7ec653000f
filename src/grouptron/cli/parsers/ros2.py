"""The parser of ``grouptron ros2`` (handler: ``grouptron.cli.ros2``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    Formatter,
    add_forecast_option,
    add_learning_options,
    add_threads_option,
    calibration_option,
    plot_region_probability,
)
from grouptron.constants import DEFAULT_CHECKPOINT


# A flat list of options, each with its help: long, but one thing to read.
def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    ros2 = commands.add_parser(
        "ros2",
        help="a live ROS 2 node: tracked people in, forecasts, markers and diagnostics out",
        formatter_class=Formatter,
        description=(
            "Join a live ROS 2 graph (pip install 'grouptron[ros2]'): forecast the newest message "
            "of tracked people on --topic and publish /grouptron/forecasts "
            "(trajectory_msgs/msg/MultiDOFJointTrajectory: joint_names the person ids, points[k-1] "
            "step k, 0.4 s apart), /grouptron/markers (visualization_msgs/msg/MarkerArray: the "
            "paths and regions, for RViz and Foxglove) and /diagnostics (the forecasts' age, "
            "inputs not forecast and why). Ctrl-C or SIGTERM stops it within a second. "
            "With --replay, publish a bag's people on --topic at their recorded rate instead, so "
            "that the node can be shown without a robot (docs/robots.md)."
        ),
        epilog="example:\n  grouptron ros2 --topic /tracked_people\n"
        "  grouptron ros2 --replay run.mcap --topic /people --out-topic /tracked_people",
    )
    ros2.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT, help="the model")
    ros2.add_argument("--topic", default="/tracked_people", help="the tracked people's topic")
    ros2.add_argument(
        "--type",
        default="visualization_msgs/msg/MarkerArray",
        help="its message type (any installed one; people_msgs/msg/People and "
        "vision_msgs/msg/Detection3DArray are read without --ros-fields)",
    )
    ros2.add_argument(
        "--ros-fields", help="where another type holds its people: people=PATH,id=PATH,x=..,y=.."
    )
    ros2.add_argument(
        "--fixed-frame", action="append", help="a frame of one's own fixed to the world"
    )
    ros2.add_argument(
        "--odom",
        metavar="TOPIC",
        help="a nav_msgs/msg/Odometry topic: people in its child frame (base_link) are put "
        "into its fixed frame (odom) at each message's stamp, forecast and published there",
    )
    ros2.add_argument(
        "--sensor-pose",
        metavar="X,Y,YAW",
        help="with --odom: people come in a sensor's frame mounted at this pose on the base "
        "(metres, radians)",
    )
    add_forecast_option(ros2, "the point forecast (default: the model's own)", samples=False)
    ros2.add_argument(
        "--regions",
        type=plot_region_probability,
        default=0.9,
        help="the probability of the region ellipses on the markers topic (0: none)",
    )
    ros2.add_argument(
        "--calibration",
        type=calibration_option,
        help="a grouptron calibrate file for the regions (without it: the shipped one; none: "
        "the model's own)",
    )
    ros2.add_argument(
        "--online", action="store_true", help="adapt the regions' radii as truths arrive"
    )
    ros2.add_argument(
        "--markers",
        choices=("light", "full", "off"),
        default="light",
        help="light: one line list of the paths and one triangle list of the horizon's "
        "regions (at most 50 KB at 100 people); full: a line per person and an ellipse per "
        "step (about 2.8 KB a person); off: no markers topic",
    )
    ros2.add_argument(
        "--costmap",
        action="store_true",
        help="also publish /grouptron/costmap (nav_msgs/msg/OccupancyGrid): the forecasts' 90%% "
        "regions, cost 100 at 0.4 s falling to 8 at 4.8 s, in a 20 m window at 0.1 m around "
        "the robot (with --odom); ROS parameters costmap_q, costmap_steps, costmap_size_m, "
        "costmap_resolution_m, costmap_centre change them (docs/robots.md)",
    )
    add_learning_options(ros2, save_site=True)
    ros2.add_argument(
        "--state",
        metavar="DIR",
        help="keep the online radii and learnt weights here (every 10 s and at exit) and take "
        "them up again when the node restarts with the same --state",
    )
    ros2.add_argument(
        "--ros-args",
        nargs=argparse.REMAINDER,
        default=[],
        help="the rest goes to ROS: parameters that override the flags of the same names "
        "(-p learn:=true, -p regions:=0.5, -p topic:=/people, -p markers:=off), each topic's "
        "QoS (-p qos_input:=depth=1,reliability=best_effort; docs/robots.md), remappings, a "
        "log level",
    )
    ros2.add_argument(
        "--lifecycle",
        action="store_true",
        help="run as a ROS 2 lifecycle node: configure loads the model, activate publishes, "
        "deactivate stops publishing, cleanup frees it (lifecycle_msgs services)",
    )
    ros2.add_argument("--replay", metavar="BAG", help="publish this bag's --topic instead")
    ros2.add_argument(
        "--out-topic", default="/tracked_people", help="with --replay: where its people go"
    )
    ros2.add_argument(
        "--seconds", type=float, help="stop after this many seconds (default: run until Ctrl-C)"
    )
    add_threads_option(
        ros2,
        default=1,
        why=" (default 1: the middleware and the other nodes need a core too; on 2 cores one "
        "thread kept the slowest tenth of forecasts within 19 ms of their input, two within "
        "24-30 ms, at the same median; benchmarks/ros2_latency.py)",
    )
    ros2.set_defaults(handler="grouptron.cli.ros2:cmd_ros2")
