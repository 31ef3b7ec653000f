"""Tracked people from ROS 2 bags (MCAP files), read without a ROS installation.

A topic of ``people_msgs/msg/People`` or ``vision_msgs/msg/Detection3DArray`` (its tracking
``id``) is read as it is; any other message that holds a list of people, each with an id and a
position, is read through a field mapping (``BagFields``, ``--ros-fields``). Times are the
message header stamps, positions metres in the header's frame, which must be fixed to the world
(``map``, ``odom``, ...): tracks in a frame that moves with the robot would be forecast as if
the robot stood still.
"""

from __future__ import annotations

import dataclasses
import importlib
import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.constants import DT_S
from grouptron.data.formats.layout import Recording, RecordingFormat
from grouptron.data.formats.plausibility import check_plausible
from grouptron.data.formats.reader import GapPolicy, TrackTable
from grouptron.data.formats.recording import resample
from grouptron.errors import GrouptronError
from grouptron.geometry import poses_at, rotation_matrix, yaw_of_quaternion

EXTRA = "pip install 'grouptron[ros]'"

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BagFields:
    """Where a message holds its people: dotted attribute paths to the list of people in the
    message and, within one person, to the id and the x and y position (metres)."""

    people: str
    id: str
    x: str
    y: str

    @classmethod
    def parse(cls, text: str) -> BagFields:
        """``"people=detections,id=id,x=bbox.center.position.x,y=bbox.center.position.y"``."""
        try:
            pairs = dict(part.split("=", 1) for part in text.split(",") if part.strip())
            return cls(**{k.strip(): v.strip() for k, v in pairs.items()})
        except (TypeError, ValueError):
            raise GrouptronError(
                f"--ros-fields takes people=PATH,id=PATH,x=PATH,y=PATH, not {text!r}"
            ) from None


KNOWN_MESSAGES = {
    "people_msgs/msg/People": BagFields("people", "name", "position.x", "position.y"),
    "vision_msgs/msg/Detection3DArray": BagFields(
        "detections", "id", "bbox.center.position.x", "bbox.center.position.y"
    ),
}
"""The message types read without a mapping, and where their people are."""
FIXED_FRAMES = ("map", "odom", "world", "earth", "utm")
"""Frame ids taken as fixed to the world (and any id starting with one of them and ``_``)."""
ROBOT_FRAME_HINTS = ("base", "link", "laser", "lidar", "scan", "camera", "optical", "velodyne")


@dataclass(frozen=True)
class BagTracks:
    """(R,) ids, (R,) times in seconds (header stamps), (R, 2) positions in metres, (R,) the
    number of the message each row came from, and the names of the ids (``names[id]``)."""

    ped_id: np.ndarray
    time_s: np.ndarray
    pos_m: np.ndarray
    message: np.ndarray
    names: tuple[str, ...]
    frame_id: str
    numeric: bool
    """Whether every id was a whole number (kept as it was) rather than a name."""

    def name(self, ped_id: int) -> str:
        """The bag's own name of an id (numeric ids are their own names)."""
        return str(int(ped_id)) if self.numeric else self.names[int(ped_id)]


def _whole_number(label: str) -> bool:
    """An id written as a whole number that float64 tables keep exactly ("01" is a name)."""
    try:
        return str(int(label)) == label and abs(int(label)) < 2**53
    except ValueError:
        return False


def _attribute(value: Any, path: str) -> Any:
    for name in path.split("."):
        value = getattr(value, name)
    return value


def _messages(path: Path, topic: str) -> Iterator[tuple[str, Any]]:
    """(message type, decoded message) of ``topic``, in log-time order."""
    try:
        mcap_reader = importlib.import_module("mcap.reader")
        decoder = importlib.import_module("mcap_ros2.decoder")
    except ImportError:
        raise GrouptronError(f"{path}: reading ROS 2 bags needs the ros extra: {EXTRA}") from None
    with Path(path).open("rb") as handle:
        reader = mcap_reader.make_reader(handle, decoder_factories=[decoder.DecoderFactory()])
        for schema, _, _, message in reader.iter_decoded_messages(topics=[topic]):
            yield schema.name, message


def topics_of(path: Path) -> dict[str, str]:
    """Topic -> message type of every channel in the bag."""
    try:
        mcap_reader = importlib.import_module("mcap.reader")
    except ImportError:
        raise GrouptronError(f"{path}: reading ROS 2 bags needs the ros extra: {EXTRA}") from None
    with Path(path).open("rb") as handle:
        summary = mcap_reader.make_reader(handle).get_summary()
    if summary is None:
        return {}
    return {
        channel.topic: summary.schemas[channel.schema_id].name
        for channel in summary.channels.values()
        if channel.schema_id in summary.schemas
    }


def is_fixed_frame(frame_id: str, fixed: tuple[str, ...] = ()) -> bool:
    """Whether a frame id names a frame fixed to the world (a known one, or one of
    ``fixed``)."""
    name = frame_id.strip("/")
    return name in (*FIXED_FRAMES, *fixed) or any(name.startswith(f"{f}_") for f in FIXED_FRAMES)


def check_fixed_frame(path: Path, frame_id: str, fixed: tuple[str, ...] = ()) -> None:
    """Refuse a frame id that is not fixed to the world, in one line."""
    if is_fixed_frame(frame_id, fixed):
        return
    name = frame_id.strip("/")
    moving = any(hint in name.lower() for hint in ROBOT_FRAME_HINTS)
    what = "moves with the robot" if moving else "is not a frame grouptron knows to be fixed"
    raise GrouptronError(
        f"{path}: the tracks are in frame {frame_id!r}, which {what}; forecasts need tracks in "
        f"a fixed frame ({', '.join(FIXED_FRAMES)}): transform them first, or name a fixed "
        "frame of your own with --fixed-frame"
    )


def read_bag(
    path: Path,
    topic: str,
    fields: BagFields | None = None,
    fixed: tuple[str, ...] = (),
    odom_topic: str | None = None,
) -> BagTracks:
    """Every person of every message on ``topic``; ids that are not whole numbers are
    numbered in order of first appearance (``names`` maps back). With ``odom_topic`` (a
    ``nav_msgs/msg/Odometry`` topic of the bag), people in its child frame are put into its
    frame at their stamps (``odometry_poses``, ``place_rows``)."""
    available = topics_of(path)
    if topic not in available:
        listed = ", ".join(f"{t} ({m})" for t, m in sorted(available.items())) or "none"
        raise GrouptronError(f"{path}: no topic {topic!r}; the bag has {listed}")
    kind = available[topic]
    fields = fields or KNOWN_MESSAGES.get(kind)
    if fields is None:
        raise GrouptronError(
            f"{path}: {topic} carries {kind}, which grouptron does not know; say where its "
            "people are with --ros-fields people=PATH,id=PATH,x=PATH,y=PATH (docs/robots.md)"
        )
    names: dict[str, int] = {}
    rows: list[tuple[int, float, float, float, int]] = []
    frame_ids: set[str] = set()
    for number, (_, message) in enumerate(_messages(path, topic)):
        stamp = message.header.stamp
        time_s = stamp.sec + 1e-9 * stamp.nanosec
        frame_ids.add(message.header.frame_id)
        try:
            for person in _attribute(message, fields.people):
                name = str(_attribute(person, fields.id))
                x, y = float(_attribute(person, fields.x)), float(_attribute(person, fields.y))
                rows.append((names.setdefault(name, len(names)), time_s, x, y, number))
        except AttributeError as error:
            raise GrouptronError(f"{path}: {topic} ({kind}): {error}; check --ros-fields") from None
    if not rows:
        raise GrouptronError(f"{path}: {topic} holds no people")
    if len(frame_ids) > 1:
        raise GrouptronError(f"{path}: {topic} mixes frames {sorted(frame_ids)}; use one")
    frame_id = frame_ids.pop()
    table = np.array(rows, dtype=np.float64)
    if odom_topic:
        table, frame_id = place_rows(path, table, frame_id, odometry_poses(path, odom_topic))
    check_fixed_frame(path, frame_id, fixed)
    labels = tuple(names)
    numeric = all(_whole_number(label) for label in labels)
    if numeric:  # numeric ids keep their numbers
        ids = np.array([int(label) for label in labels])[table[:, 0].astype(np.int64)]
    else:
        ids = table[:, 0].astype(np.int64)
    return BagTracks(
        ids, table[:, 1], table[:, 2:4], table[:, 4].astype(np.int64), labels, frame_id, numeric
    )


@dataclass(frozen=True)
class Odometry:
    """A bag's odometry: (P,) increasing times, (P, 3) poses x, y, yaw of the base, the fixed
    frame they are in and the base's frame."""

    time_s: np.ndarray
    poses: np.ndarray
    frame_id: str
    child_frame_id: str


def odometry_poses(path: Path, topic: str) -> Odometry:
    """The ``nav_msgs/msg/Odometry`` messages of ``topic``, in time order."""
    available = topics_of(path)
    if available.get(topic) != "nav_msgs/msg/Odometry":
        found = available.get(topic, "no such topic")
        raise GrouptronError(f"{path}: {topic} is not nav_msgs/msg/Odometry ({found})")
    rows, frames = [], set()
    for _, message in _messages(path, topic):
        stamp, pose = message.header.stamp, message.pose.pose
        q = pose.orientation
        yaw = yaw_of_quaternion(q.x, q.y, q.z, q.w)
        rows.append((stamp.sec + 1e-9 * stamp.nanosec, pose.position.x, pose.position.y, yaw))
        frames.add((message.header.frame_id.strip("/"), message.child_frame_id.strip("/")))
    if len(frames) != 1:
        raise GrouptronError(f"{path}: {topic} holds no odometry, or mixes frames {frames}")
    table = np.array(rows, dtype=np.float64)
    table = table[np.argsort(table[:, 0], kind="stable")]
    ((frame_id, child),) = frames
    return Odometry(table[:, 0], table[:, 1:4], frame_id, child)


ODOMETRY_MAX_GAP_S = 0.5
"""Odometry messages further apart than this are not interpolated between."""


def place_rows(
    path: Path, table: np.ndarray, frame_id: str, odometry: Odometry
) -> tuple[np.ndarray, str]:
    """(R, 5) rows (id, t, x, y, message) of people in the odometry's child frame put into its
    frame at their stamps, and that frame; rows the odometry does not cover are dropped with a
    warning. Rows already in a fixed frame (the odometry's, or a known one) are returned as
    they are."""
    if frame_id.strip("/") == odometry.frame_id or is_fixed_frame(frame_id):
        return table, frame_id
    if frame_id.strip("/") != odometry.child_frame_id:
        raise GrouptronError(
            f"{path}: the tracks are in frame {frame_id!r}, the odometry moves "
            f"{odometry.child_frame_id!r} in {odometry.frame_id!r}: tracks must be in one of them"
        )
    pose, found = poses_at(odometry.time_s, odometry.poses, table[:, 1], ODOMETRY_MAX_GAP_S)
    if not found.any():
        raise GrouptronError(f"{path}: the odometry covers none of the tracks' stamps")
    if not found.all():
        log.warning(
            "%s: %d of %d people's sightings have no odometry at their stamp: left out",
            *(path, int((~found).sum()), len(found)),
        )
    placed = table[found].copy()
    rotation = rotation_matrix(pose[found, 2])  # (R, 2, 2)
    placed[:, 2:4] = np.einsum("rij,rj->ri", rotation, placed[:, 2:4]) + pose[found, :2]
    return placed, odometry.frame_id


BAG_FORMAT = RecordingFormat(columns=("t", "id", "x", "y"))
"""How a bag's rows are read: seconds (header stamps), ids and positions in metres."""


def read_bag_table(  # noqa: PLR0913 - a bag and how to read it, keyword-only past four
    path: Path,
    topic: str,
    fields: BagFields | None = None,
    fixed: tuple[str, ...] = (),
    *,
    odom_topic: str | None = None,
    max_gap_s: float | None = None,
    check_speed: bool = True,
    on_gap: GapPolicy = "split",
    dt_s: float = DT_S,
) -> tuple[TrackTable, BagTracks]:
    """A bag topic's people on the ``dt_s`` grid from its first stamp (``TrackTable.frame``
    counts grid steps; ``first_frame`` 0), as a ``t,id,x,y`` file of the same rows would be."""
    bag = read_bag(path, topic, fields, fixed, odom_topic)
    fmt = dataclasses.replace(
        BAG_FORMAT,
        check_speed=check_speed,
        max_gap_s=BAG_FORMAT.max_gap_s if max_gap_s is None else max_gap_s,
    )
    recording = Recording(
        Path(path), bag.ped_id, bag.time_s, bag.pos_m, bag.message + 1, own_times=True
    )
    if check_speed:
        check_plausible(recording, fmt)
    return resample(recording, fmt, dt_s, on_gap), bag
