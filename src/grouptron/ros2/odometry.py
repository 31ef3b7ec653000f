"""People seen from a moving base, put into the odometry's fixed frame (no graph here).

A tracker on a robot publishes people in ``base_link`` (the odometry's child frame) or in a
sensor's frame mounted on it at a fixed pose. With ``nav_msgs/msg/Odometry`` the node knows
where the base was at each message's stamp (interpolated between odometry messages: positions
linearly, the heading along the shorter turn) and places the people in the odometry's own
frame (``odom``), where they are forecast and published: the robot's motion never becomes the
people's. A stamp later than the newest odometry waits for it (at most ``WAIT_S``); one that
the odometry kept does not cover (older than ``KEEP_S``, or across a gap) is refused and
counted.
"""

from __future__ import annotations

import enum
from pathlib import Path

import numpy as np

from grouptron.data.formats.ros_bag import check_fixed_frame
from grouptron.errors import GrouptronError
from grouptron.geometry import compose_poses, fixed_from_body, poses_at
from grouptron.inference.track_faults import LATE_TOLERANCE_S
from grouptron.ros2.messages import Tracked

KEEP_S = 10.0
"""Odometry older than this (behind its newest message) is dropped."""
WAIT_S = 0.2
"""A message stamped after the newest odometry waits this long for it (wall clock)."""
MAX_GAP_S = 0.5
"""Odometry messages further apart than this are not interpolated between."""


class Placement(enum.Enum):
    """A message that cannot be placed yet."""

    WAIT = "wait"  # stamped after the newest odometry: it may come


class OdometryTrack:
    """The base's poses from odometry messages: the last ``KEEP_S`` seconds of them.

    Attributes:
        fixed_frame: the odometry's frame (``header.frame_id``, e.g. ``odom``).
        base_frame: the frame it moves (``child_frame_id``, e.g. ``base_link``).
        sensor_pose: (3,) where people given in another moving frame are seen from on the
            base (x, y, yaw), or None: only ``base_frame`` is placed.
    """

    def __init__(self, sensor_pose: np.ndarray | None = None) -> None:
        self.fixed_frame = ""
        self.base_frame = ""
        self.sensor_pose = sensor_pose
        self.times_s = np.zeros(0)
        self.poses = np.zeros((0, 3))

    def add(self, t_s: float, pose: np.ndarray, fixed_frame: str, base_frame: str) -> None:
        """One odometry message: the base's (3,) pose at ``t_s``. A time at most
        ``LATE_TOLERANCE_S`` before the newest is dropped; one further back is a clock that
        went back (a bag looping): the record starts again."""
        if len(self.times_s) and t_s <= self.times_s[-1]:
            if self.times_s[-1] - t_s <= LATE_TOLERANCE_S:
                return  # a repeated or slightly late stamp: the record has it or around it
            self.times_s, self.poses = np.zeros(0), np.zeros((0, 3))
        keep = self.times_s >= t_s - KEEP_S
        self.times_s = np.append(self.times_s[keep], t_s)
        self.poses = np.vstack([self.poses[keep], pose[None]])
        self.fixed_frame, self.base_frame = fixed_frame.strip("/"), base_frame.strip("/")

    def moves(self, frame_id: str, fixed: tuple[str, ...] = ()) -> bool:
        """Whether people in ``frame_id`` are placed through the odometry: the base's frame,
        or with a sensor pose any frame but a fixed one (the odometry's, a known one, or one
        of ``fixed``). Before the first odometry, every frame not fixed is (and waits for
        it, or is refused for want of it)."""
        name = frame_id.strip("/")
        if name == self.fixed_frame:
            return False
        try:
            check_fixed_frame(Path("odometry"), name, fixed)
            return False
        except GrouptronError:
            pass  # a frame that moves, or one grouptron does not know to be fixed
        if not self.base_frame:
            return True
        return name == self.base_frame or self.sensor_pose is not None

    def position_at(self, t_s: float) -> np.ndarray:
        """(2,) the base's position at ``t_s`` (the nearest kept pose outside the record;
        the origin before any odometry)."""
        if not len(self.times_s):
            return np.zeros(2)
        pose, found = poses_at(self.times_s, self.poses, np.array([t_s]), MAX_GAP_S)
        if found[0]:
            return pose[0, :2]
        nearest = int(np.argmin(np.abs(self.times_s - t_s)))
        position: np.ndarray = self.poses[nearest, :2]
        return position

    def place(self, people: Tracked) -> Tracked | Placement:
        """``people`` in the fixed frame at their stamp, or ``Placement.WAIT`` while the
        odometry has not reached it; refused in one line where it does not cover it."""
        if len(self.times_s) and people.time_s > self.times_s[-1]:
            return Placement.WAIT
        pose, found = poses_at(self.times_s, self.poses, np.array([people.time_s]), MAX_GAP_S)
        if not found[0]:
            raise GrouptronError(
                f"no odometry at {people.time_s:.3f} s: the kept odometry covers "
                + (
                    f"{self.times_s[0]:.3f}-{self.times_s[-1]:.3f} s with gaps up to {MAX_GAP_S} s"
                    if len(self.times_s)
                    else "nothing yet"
                )
            )
        base = pose[0]
        if people.frame_id.strip("/") != self.base_frame and self.sensor_pose is not None:
            base = compose_poses(base, self.sensor_pose)
        xy = fixed_from_body(people.xy, base)
        return Tracked(people.time_s, self.fixed_frame, people.ids, xy, people.stamp)
