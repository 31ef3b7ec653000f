"""The node's work between a message of tracked people and what it publishes, without a graph:
checks, the session's update, its regions, and the health counts (``ros2.health``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.data.formats.ros_bag import check_fixed_frame
from grouptron.errors import GrouptronError, LateUpdateError
from grouptron.inference.forecast import Forecast
from grouptron.inference.stream import StreamSession
from grouptron.model.regions import Regions
from grouptron.ros2.health import Health
from grouptron.ros2.messages import Tracked
from grouptron.ros2.odometry import OdometryTrack, Placement


@dataclass(frozen=True)
class Made:
    """A forecast ready to publish.

    Attributes:
        forecast: the session's forecast.
        regions: its q-regions (None: none asked for, or nobody forecast).
        now_xy: (N, 2) where each forecast person is in the input (where their path starts).
        update_ms: the update's own time (regions included).
        frame_id: the frame it is in (the odometry's, for people seen from a moving base).
    """

    forecast: Forecast
    regions: Regions | None
    now_xy: np.ndarray
    update_ms: float
    frame_id: str


class LiveForecaster:
    """Forecasts messages of tracked people with a session, and counts what happened.

    Args:
        session: the live session (``Predictor.stream``).
        topic: the input topic (named in refusals).
        fixed_frames: frames of one's own fixed to the world.
        regions_q: the q of the regions drawn (0: none).
        clock_s: the monotonic clock the health counts use.
        odometry: the base's poses, which put people seen from it into its fixed frame
            (``ros2.odometry``), or None: people come in a fixed frame.
    """

    def __init__(
        self,
        session: StreamSession,
        topic: str,
        fixed_frames: tuple[str, ...] = (),
        regions_q: float = 0.9,
        clock_s: Callable[[], float] = time.monotonic,
        odometry: OdometryTrack | None = None,
    ) -> None:
        self.session = session
        self.odometry = odometry
        self.topic = topic
        self.fixed_frames = fixed_frames
        self.regions_q = regions_q
        self.clock_s = clock_s
        self.health = Health()

    def forecast(self, people: Tracked) -> Made | Placement | None:
        """The forecast of ``people``; ``Placement.WAIT`` while the odometry has not reached
        their stamp; None when the message is refused (counted by kind in ``health``: ``late``,
        ``no odometry``, or ``malformed`` for anything else the session or the frame check
        refuses, with the reason)."""
        started = time.perf_counter()
        if self.odometry is not None and self.odometry.moves(people.frame_id, self.fixed_frames):
            try:
                placed = self.odometry.place(people)
            except GrouptronError as error:
                self.refused("no odometry", str(error))
                return None
            if placed is Placement.WAIT:
                return placed
            people = placed
        try:
            check_fixed_frame(Path(self.topic), people.frame_id, self.fixed_frames)
            forecast = self.session.update(people.time_s, people.ids, people.xy)
        except LateUpdateError as error:
            self.refused("late", str(error))
            return None
        except GrouptronError as error:
            self.refused("malformed", str(error))
            return None
        regions = forecast.regions(self.regions_q) if self.regions_q and len(forecast) else None
        update_ms = 1000 * (time.perf_counter() - started)
        # Where each forecast person is in the message: their ids found in one sorted pass.
        given = np.asarray(people.ids, dtype=str)
        order = np.argsort(given)
        at = order[np.searchsorted(given[order], forecast.ids.astype(str))]
        now_xy = people.xy[at].reshape(-1, 2)
        return Made(forecast, regions, now_xy, update_ms, people.frame_id)

    def refused(self, kind: str, reason: str) -> None:
        """Count an input refused before or by the session (``kind``: malformed, late)."""
        self.health.refused_input(kind, reason, self.clock_s())

    def faults(self) -> dict[str, str]:
        """The session's survived faults and what it adapts, for the diagnostics."""
        faults = self.session.faults
        learning = self.session.learning
        return {
            "clock resets": str(faults.clock_resets),
            "id restarts": str(faults.id_restarts),
            "learning": "off" if learning is None else learning.line(),
        }
