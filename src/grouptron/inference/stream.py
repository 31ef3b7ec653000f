"""Live forecasting: a session fed one frame of tracker output at a time."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.inference.forecast import Forecast
from grouptron.inference.inputs import as_track_array, frame_argument, frame_arrays

if TYPE_CHECKING:
    from grouptron.inference.predictor import Predictor

STREAM_MIN_PAIRS = 30
"""A stream's speeds are judged once it holds this many consecutive observations, and in any
case before its first forecast leaves (with the pairs there are then, as ``predict`` does)."""


class StreamSession:
    """Feeds a :class:`Predictor` one frame at a time.

    Keeps the last ``Predictor.window_frames`` of rows (the history, the two steps before it
    and room for a missed detection at its start); agents appear and vanish freely, and up to
    ``Predictor.max_missed_steps`` missed detections in a row are filled once the agent is
    seen again (a longer gap restarts its track).
    """

    def __init__(self, predictor: Predictor) -> None:
        self.predictor = predictor
        self._rows = np.zeros((0, 4))
        self._last_frame: int | None = None
        self._judged = False  # units and frame grid judged plausible once (they do not change)

    @property
    def window_frames(self) -> int:
        return self.predictor.window_frames

    def update(
        self, frame: int, ids: Any, xy: Any, num_samples: int = 0, *, seed: int = 0
    ) -> Forecast:
        """Add the agents observed at ``frame`` ((N,) ids, (N, 2) positions in metres) and
        forecast every agent with enough history."""
        frame = frame_argument(frame, "frame")
        ids_arr, xy_arr = frame_arrays(frame, ids, xy)
        if self._last_frame is not None:
            if frame <= self._last_frame:
                raise GrouptronError(
                    f"frame {frame} is not after the previous frame {self._last_frame}"
                )
            if (frame - self._last_frame) % self.predictor.frames_per_step:
                raise GrouptronError(
                    f"frame {frame} is not on the {self.predictor.frames_per_step}-frame grid of "
                    f"the previous frame {self._last_frame}"
                )
        new = np.column_stack([np.full(len(ids_arr), float(frame)), ids_arr, xy_arr])
        as_track_array(new)  # finite, shape
        rows = np.concatenate([self._rows, new])
        rows = rows[rows[:, 0] >= frame - self.window_frames]
        judged = self._judged or self.predictor.check_plausible(rows, min_pairs=STREAM_MIN_PAIRS)
        forecast = self.predictor._forecast(rows, frame, num_samples, seed)
        if not judged and len(forecast):
            # No forecast leaves unjudged: one or two people never fill the window with
            # STREAM_MIN_PAIRS observations, and a centimetre stream would pass unseen.
            judged = self.predictor.check_plausible(rows)
        # Kept only once the update is accepted: a refused one leaves the session as it was.
        self._rows, self._last_frame, self._judged = rows, frame, judged
        return forecast
