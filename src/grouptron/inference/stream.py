"""Live forecasting: a session fed one frame of tracker output at a time."""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch

from grouptron.errors import GrouptronError, LateUpdateError
from grouptron.geometry import fixed_from_body
from grouptron.inference.forecast import Forecast
from grouptron.inference.inputs import (
    MAX_MISSED_STEPS,
    as_track_array,
    frame_argument,
    frame_arrays,
)
from grouptron.inference.learning import LearningStatus, SiteLearner
from grouptron.inference.live import IdBook, LiveTracks
from grouptron.inference.online import OnlineCalibration
from grouptron.inference.session_state import resume_session_state, save_session_state
from grouptron.inference.site_model import save_site
from grouptron.inference.track_faults import (
    JUMP_FORWARD_S,
    LATE_TOLERANCE_S,
    Clock,
    StreamFaults,
    clock_step,
    unreachable_rows,
)
from grouptron.model.regions import region_shapes


class WindowForecaster(Protocol):
    """What a session needs of a predictor (``Predictor`` is one); a protocol, so that this
    module does not import the predictor that imports it."""

    check_speed: bool
    config: Any
    model: Any
    threads: int | None

    @property
    def window_frames(self) -> int:
        """Frames before ``t`` a forecast reads (``Predictor.window_frames``)."""
        ...

    @property
    def frames_per_step(self) -> int:
        """Frame numbers between consecutive steps."""
        ...

    def check_plausible(self, values: np.ndarray, min_pairs: int = 1) -> bool:
        """Refuse (R, 4) rows whose speeds no pedestrian walks; returns whether there were
        ``min_pairs`` consecutive observations to judge."""
        ...

    def forecast_window(
        self, values: np.ndarray, frame: int, num_samples: int, seed: int
    ) -> Forecast:
        """The forecast at ``frame`` of (R, 4) rows already cut to the window; columns frame, id,
        x, y (metres)."""
        ...


log = logging.getLogger(__name__)

CLOCK_RESET_GAP_S = 60.0
"""After a clock jump the learner's time goes on this much later than the last update's, so
that no track it keeps joins positions from both sides of the jump."""

STREAM_MIN_PAIRS = 30
"""A stream's speeds are judged once it holds this many consecutive observations, and in any
case before its first forecast leaves (with the pairs there are then, as ``predict`` does)."""


class StreamSession:
    """Feeds a :class:`Predictor` one frame at a time.

    Keeps the last ``Predictor.window_frames`` of rows (the history, the two steps before it
    and room for a missed detection at its start); agents appear and vanish freely, and up to
    ``Predictor.max_missed_steps`` missed detections in a row are filled once the agent is
    seen again (a longer gap restarts its track). A sighting where no walker gets to from the
    person's last (``track_faults.unreachable``: a glitch, an id swap, a reused id; a stream
    cannot wait to see which) restarts the person's track from it, with a warning, so that
    the jump never reaches a forecast. A clock that jumps restarts the whole history with a
    warning, and an update slightly out of order raises ``LateUpdateError`` and changes nothing
    (``track_faults``; counted in ``faults``).
    """

    def __init__(
        self,
        predictor: WindowForecaster,
        online: OnlineCalibration | None = None,
        learner: SiteLearner | None = None,
    ) -> None:
        self.predictor = predictor
        self.online = online
        """With online calibration, its state: per q and step the radii in force, adapted to
        every forecast whose truth arrived (``online.save(path)`` keeps it; ``None``: off)."""
        self.learner = learner
        """With online learning, the session's learner (its own copy of the weights, which
        forecasts use; ``inference.learning``); ``None``: off."""
        self._rows = np.zeros((0, 4))
        self._last_frame: int | None = None
        self._judged = False  # units and frame grid judged plausible once (they do not change)
        self._book: IdBook | None = None  # where ids are not all numbers, or times in seconds
        self._live: LiveTracks | None = None  # a tracker's own rate: times in seconds
        self.faults = StreamFaults()
        """Late updates dropped, clock jumps and reused ids survived so far."""
        # The learner's clock runs on across clock jumps (None: set at the next update).
        self._learner_offset_s: float | None = 0.0
        self._learner_last_s: float | None = None

    @property
    def learning(self) -> LearningStatus | None:
        """What online learning has done so far (rounds, accepted, rolled back, the last
        paired FDE difference); None without learning."""
        return None if self.learner is None else self.learner.status

    def close(self, drop_round: bool = False) -> None:
        """Finish a learning round still running (up to 10 s; ``drop_round``: drop it at once,
        as a node that stops within a second does) and stop the learning process (a session
        that does not learn has nothing to close)."""
        if self.learner is not None:
            self.learner.close(drop_round)

    def save_site(self, path: str | Path) -> Path:
        """Keep the weights in use and their card in the folder ``path`` (``best.safetensors``,
        ``site.json``; ``Predictor.from_checkpoint(path)`` loads it); returns the weights'
        file. A round still running is waited for."""
        if self.learner is None:
            raise GrouptronError("save_site needs a session that learns (stream(learn=True))")
        self.learner.wait()
        source = getattr(self.predictor, "source", "")
        config = self.predictor.config
        return save_site(path, self.learner.model, config, self.learner.status, source)

    def save_state(self, folder: str | Path, *, site: bool = True) -> list[Path]:
        """Keep what this session adapted to its site in ``folder``, for a session started
        after a restart with ``Predictor.stream(state=folder)`` (``session_state``): the
        online radii and, with ``site``, the learnt weights in use; returns the files."""
        return save_session_state(self, Path(folder), site)

    def resume_state(self, folder: str | Path) -> list[str]:
        """Take up what ``save_state`` kept in ``folder`` (nothing there yet: a first start);
        returns what was resumed, by name."""
        return resume_session_state(self, Path(folder))

    @property
    def window_frames(self) -> int:
        """Frames before the current one whose rows the session keeps (the predictor's)."""
        return self.predictor.window_frames

    def update(
        self,
        frame: int | float,
        ids: Any,
        xy: Any,
        num_samples: int = 0,
        *,
        seed: int = 0,
        pose: Any = None,
    ) -> Forecast:
        """Add the agents observed at ``frame`` ((N,) ids, (N, 2) positions in metres) and
        forecast every agent with enough history.

        ``frame``: a time in seconds (a float: a tracker's stamp, at any rate and regularity;
        the history is resampled onto the model's step at every update, ``inference.live``),
        or a frame number (an int, 10 per 0.4 s step as in ETH/UCY). Ids: any hashable
        values (numbers, strings); a forecast's ``ids`` are the ones given. ``pose``: where
        ``xy`` are given in a moving robot's frame (x forward, y left), the robot's (3,) pose
        in the fixed frame at this time, x, y (metres) and yaw (radians): the people are put
        into the fixed frame first, and forecast there (the robot's motion never becomes
        theirs).
        """
        if pose is not None:
            xy = _in_fixed_frame(xy, pose, f"frame {frame}")
        if isinstance(frame, float | np.floating):
            return self._update_seconds(float(frame), ids, xy, num_samples, seed)
        if self._live is not None:
            raise GrouptronError(
                f"frame {frame}: this session was fed times in seconds; keep to seconds (floats)"
            )
        frame = frame_argument(frame, "frame")
        if self._book is not None or not _numeric(ids):
            return self._update_named_frame(frame, ids, xy, num_samples, seed)
        return self._update_frame(frame, ids, xy, num_samples, seed)

    def _update_frame(self, frame: int, ids: Any, xy: Any, num_samples: int, seed: int) -> Forecast:
        """An update at a frame number, ids numbers (the session as it always was)."""
        ids_arr, xy_arr = frame_arrays(frame, ids, xy)
        seconds_per_frame = self.predictor.config.data.dt_s / self.predictor.frames_per_step
        if self._last_frame is not None:
            clock = clock_step(self._last_frame * seconds_per_frame, frame * seconds_per_frame)
            if clock is Clock.LATE:
                self._late(f"frame {frame}", f"the previous frame {self._last_frame}")
            if clock is not Clock.NEXT:
                self._restart_clock(f"frame {frame}", clock)
        last = self._last_frame  # None after a clock jump: any grid starts again
        if last is not None and (frame - last) % self.predictor.frames_per_step:
            raise GrouptronError(
                f"frame {frame} is not on the {self.predictor.frames_per_step}-frame grid of "
                f"the previous frame {self._last_frame}"
            )
        new = np.column_stack([np.full(len(ids_arr), float(frame)), ids_arr, xy_arr])
        as_track_array(new)  # finite, shape
        # Jumps are judged once the units are: a stream in centimetres is refused, not
        # restarted at every step.
        kept = self._restart_jumped(self._rows, new, frame) if self._judged else self._rows
        rows = np.concatenate([kept, new])
        rows = rows[rows[:, 0] >= frame - self.window_frames]
        judged = self._judged or self.predictor.check_plausible(rows, min_pairs=STREAM_MIN_PAIRS)
        with self._learnt_weights():
            forecast = self.predictor.forecast_window(rows, frame, num_samples, seed)
        if not judged and len(forecast):
            # No forecast leaves unjudged: one or two people never fill the window with
            # STREAM_MIN_PAIRS observations, and a centimetre stream would pass unseen.
            judged = self.predictor.check_plausible(rows)
        # Kept only once the update is accepted: a refused one leaves the session as it was.
        self._rows, self._last_frame, self._judged = rows, frame, judged
        # As a file's replay counts it (steps * dt_s), so that both learn from the same times.
        t_s = frame / self.predictor.frames_per_step * self.predictor.config.data.dt_s
        self._learn(t_s, ids_arr.astype(np.int64), xy_arr)
        return self._calibrated_online(forecast, frame, ids_arr, xy_arr)

    def _update_named_frame(
        self, frame: int, ids: Any, xy: Any, num_samples: int, seed: int
    ) -> Forecast:
        """A frame-numbered update whose ids are not all numbers: numbered, then named back."""
        self._book = self._book or IdBook()
        names = list(ids) if not isinstance(ids, np.ndarray) else ids
        codes = self._book.encode(names, f"frame {frame}")
        forecast = self._update_frame(frame, codes.astype(np.float64), xy, num_samples, seed)
        return _named(forecast, self._book)

    def _update_seconds(
        self, t_s: float, ids: Any, xy: Any, num_samples: int, seed: int
    ) -> Forecast:
        """An update at a time in seconds: the history resampled onto the step, ending at
        ``t_s``; answered at every update."""
        where = f"time {t_s} s"
        if not math.isfinite(t_s):
            raise GrouptronError(f"{where}: a time must be a finite number of seconds")
        if self._last_frame is not None:
            raise GrouptronError(f"{where}: this session was fed frame numbers; keep to ints")
        xy_arr = _positions(xy, len(ids) if hasattr(ids, "__len__") else -1, where)
        predictor, data = self.predictor, self.predictor.config.data
        if self._live is None:
            window = (self.window_frames / self.predictor.frames_per_step + 1) * data.dt_s
            gap = (getattr(predictor, "max_missed_steps", MAX_MISSED_STEPS) + 1) * data.dt_s
            self._live = LiveTracks(window, gap, predictor.check_speed)
            self._book = IdBook()
        assert self._book is not None
        clock = clock_step(self._live.last_s, t_s)  # judged first: a late update changes nothing
        if clock is Clock.LATE:
            self._late(where, f"the previous update's {self._live.last_s} s")
        codes = self._book.encode(list(ids) if not isinstance(ids, np.ndarray) else ids, where)
        if clock is not Clock.NEXT:
            self._restart_clock(where, clock)
        since = self._live.last_s
        jumped = self._live.add(t_s, codes, xy_arr)
        if jumped:
            self.faults.id_restarts += len(jumped)
            names = ", ".join(f"id {n}" for n in self._book.decode(np.array(jumped))[:5])
            log.warning(_REUSED, where, names + (" ..." if len(jumped) > 5 else ""))
        steps = self.window_frames // self.predictor.frames_per_step + 1
        step = self.predictor.frames_per_step
        rows = self._live.grid_rows(t_s, codes, steps, data.dt_s, step)
        now = (steps - 1) * step
        judged = self._judged or predictor.check_plausible(rows, min_pairs=STREAM_MIN_PAIRS)
        with self._learnt_weights():
            forecast = predictor.forecast_window(rows, now, num_samples, seed)
        if not judged and len(forecast):
            judged = predictor.check_plausible(rows)
        self._judged = judged
        self._learn(t_s, codes, xy_arr)
        forecast = dataclasses.replace(forecast, frame=None, time_s=t_s)
        if self.online is not None:
            live = self._live
            if since is not None:
                self.online.observe_between(since, t_s, data.dt_s, live.positions_at)
            forecast = dataclasses.replace(forecast, calibration=self.online.calibration())
            if len(forecast) and forecast.distribution is not None:
                shapes = region_shapes(forecast.point, forecast.distribution)
                self.online.remember(t_s, forecast.ids, forecast.point, shapes, data.dt_s)
        return _named(forecast, self._book)

    def _late(self, where: str, previous: str) -> None:
        """Drop an update slightly out of order: counted, raised, the session unchanged."""
        self.faults.late += 1
        raise LateUpdateError(
            f"{where} is not after {previous} (late by at most {LATE_TOLERANCE_S:g} s: a "
            "message out of order); dropped"
        )

    def _restart_clock(self, where: str, clock: Clock) -> None:
        """The clock jumped: forget every history (the new times do not follow the old ones)
        and the forecasts awaiting truths; forecasts resume once people have two steps."""
        self.faults.clock_resets += 1
        what = (
            "jumped back"
            if clock is Clock.JUMPED_BACK
            else f"jumped forward (or no update came for over {JUMP_FORWARD_S:g} s)"
        )
        log.warning("%s: the clock %s; every track restarts from this update", where, what)
        self._rows = np.zeros((0, 4))
        self._last_frame = None
        if self._live is not None:
            self._live = LiveTracks(
                self._live.window_s, self._live.max_gap_s, self._live.check_speed
            )
        if self.online is not None:
            self.online.forget_pending()
        if self._learner_last_s is not None:
            self._learner_offset_s = None

    def _learn(self, t_s: float, codes: np.ndarray, xy: np.ndarray) -> None:
        """Hand the update to the learner on its own clock, which runs on across clock jumps
        (``CLOCK_RESET_GAP_S`` later, so that no track it keeps spans one)."""
        if self.learner is None:
            return
        if self._learner_offset_s is None:  # the first update after a jump
            assert self._learner_last_s is not None
            self._learner_offset_s = self._learner_last_s + CLOCK_RESET_GAP_S - t_s
        self._learner_last_s = t_s + self._learner_offset_s
        self.learner.observe(self._learner_last_s, codes, xy)

    @contextmanager
    def _learnt_weights(self) -> Iterator[None]:
        """Forecast with the weights the learner has in use now (a round may have replaced
        them since the last update), on the cores a running round leaves."""
        if self.learner is None:
            yield
            return
        self.predictor.model = self.learner.model
        wanted = self.predictor.threads
        self.predictor.threads = self.learner.threads_left(wanted or torch.get_num_threads())
        try:
            yield
        finally:
            self.predictor.threads = wanted

    def _calibrated_online(
        self, forecast: Forecast, frame: int, ids: np.ndarray, xy: np.ndarray
    ) -> Forecast:
        """With online calibration: score the earlier forecasts whose truths arrived now, and
        give this one the radii in force (strictly causal: only truths seen by ``frame``)."""
        if self.online is None:
            return forecast
        step = self.predictor.frames_per_step
        self.online.observe(frame, ids, xy, step)
        forecast = dataclasses.replace(forecast, calibration=self.online.calibration())
        if len(forecast) and forecast.distribution is not None:
            shapes = region_shapes(forecast.point, forecast.distribution)
            self.online.remember(frame, forecast.ids, forecast.point, shapes, step)
        return forecast

    def _restart_jumped(self, rows: np.ndarray, new: np.ndarray, frame: int) -> np.ndarray:
        """The (R, 4) window ``rows`` without the history of every person in ``new`` ((N, 4)
        rows at ``frame``) who reappeared where no walker gets to, with a warning; unchanged
        when the speed check is off (runners, vehicles)."""
        if not self.predictor.check_speed:
            return rows
        step = self.predictor.frames_per_step
        jumped = unreachable_rows(rows, new, step, self.predictor.config.data.dt_s / step)
        if not jumped.size:
            return rows
        self.faults.id_restarts += int(jumped.size)
        names = ", ".join(f"id {int(i)}" for i in jumped[:5]) + (" ..." if jumped.size > 5 else "")
        log.warning(_REUSED, f"frame {frame}", names)
        return rows[~np.isin(rows[:, 1], jumped)]


_REUSED = (
    "%s: %s reappeared where no walker gets to since last seen (a reused id or an id swap): "
    "their tracks restart"
)


def _numeric(ids: Any) -> bool:
    """Whether every id is a number (the frame-numbered session's ids as they always were)."""
    try:
        np.asarray(ids, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return True


def _positions(xy: Any, count: int, where: str) -> np.ndarray:
    """(N, 2) finite positions for ``count`` ids, refused in one line otherwise."""
    try:
        xy_arr = np.asarray(xy, dtype=np.float64).reshape(-1, 2) if count else np.zeros((0, 2))
    except (TypeError, ValueError):
        raise GrouptronError(f"{where}: positions must be numbers, (N, 2) x, y") from None
    if len(xy_arr) != count or not np.isfinite(xy_arr).all():
        raise GrouptronError(
            f"{where}: positions must be (N, 2) = ({count}, 2) finite numbers, one row per id"
        )
    return xy_arr


def _in_fixed_frame(xy: Any, pose: Any, where: str) -> np.ndarray:
    """(N, 2) positions given in a body's frame, in the fixed frame where ``pose`` puts it."""
    try:
        pose_arr = np.asarray(pose, dtype=np.float64).reshape(3)
        xy_arr = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    except (TypeError, ValueError):
        raise GrouptronError(
            f"{where}: pose must be (x, y, yaw) numbers and positions (N, 2) numbers"
        ) from None
    if not np.isfinite(pose_arr).all():
        raise GrouptronError(f"{where}: pose must be finite numbers, not {pose_arr.tolist()}")
    return fixed_from_body(xy_arr, pose_arr)


def _named(forecast: Forecast, book: IdBook) -> Forecast:
    """The forecast with the ids as given (its rows in that order where they are numbers)."""
    names = book.decode(forecast.ids.astype(np.int64))
    if names.dtype == object:
        return dataclasses.replace(forecast, ids=names)
    order = np.argsort(names, kind="stable")
    return forecast.rows(order, ids=names[order])
