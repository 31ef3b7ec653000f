"""How a table's frame numbers map to the time of the file it was read from."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grouptron.constants import DT_S


@dataclass(frozen=True)
class TimeBase:
    """How a table's frame numbers map to the file's own time: ``origin_s + frame *
    seconds_per_frame`` seconds, and the file's own frame numbers when it has them.

    Attributes:
        origin_s: the file's time at table frame 0 (its first time for a resampled file).
        seconds_per_frame: seconds per table frame.
        file_fps: frames per second of the file's own frame numbers (None: its times are
            seconds, it has no frame numbers).
    """

    origin_s: float
    seconds_per_frame: float
    file_fps: float | None

    def seconds(self, frame: np.ndarray) -> np.ndarray:
        """(N,) the file's time of (N,) table frames."""
        return self.origin_s + np.asarray(frame, dtype=np.float64) * self.seconds_per_frame

    def file_frames(self, frame: np.ndarray) -> np.ndarray | None:
        """(N,) the file's own frame number of (N,) table frames (the nearest where a 0.4 s
        step is not a whole number of frames), or None for a file in seconds."""
        if self.file_fps is None:
            return None
        return np.rint(self.seconds(frame) * self.file_fps).astype(np.int64)

    def table_frame(self, seconds: float) -> int:
        """The table frame at (or nearest to) a time of the file."""
        return round((seconds - self.origin_s) / self.seconds_per_frame)


def frames_time_base(frames_per_step: int, dt_s: float = DT_S) -> TimeBase:
    """An ETH/UCY-style file's: its frame numbers, ``frames_per_step`` of them per step."""
    return TimeBase(0.0, dt_s / frames_per_step, frames_per_step / dt_s)


def resampled_time_base(
    first_time_s: float, seconds_per_frame: float | None, own_frames: bool, dt_s: float = DT_S
) -> TimeBase:
    """A resampled file's: its own frame numbers when the table keeps them (``own_frames``),
    else 0.4 s steps from its first time; ``seconds_per_frame`` None for a file in seconds."""
    if seconds_per_frame is None:
        return TimeBase(first_time_s, dt_s, None)
    if own_frames:
        return TimeBase(0.0, seconds_per_frame, 1.0 / seconds_per_frame)
    return TimeBase(first_time_s, dt_s, 1.0 / seconds_per_frame)
