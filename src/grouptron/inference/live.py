"""A tracker's output at its own rate: times in seconds, any hashable ids, resampled causally
onto the model's step.

A tracker publishes at 10-30 Hz, with jitter and dropped messages, and names people as it
likes (numbers, strings such as ``people_msgs`` names). :class:`LiveTracks` keeps each
person's observations of the last few seconds and, at every update at time t, lays the history
a forecast reads on the grid t, t - 0.4 s, t - 0.8 s, ...: each grid position interpolated
between the person's two observations around it (both at or before t: strictly causal), where
they are at most ``max_gap_s`` apart. A person seen at t with enough grid points is forecast
from t itself, so every update is answered.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.inference.track_faults import VELOCITY_BASE_S, unreachable

TIME_TOLERANCE_S = 1e-6
"""Times this close are one time (a grid time and an observation's)."""


@dataclass
class IdBook:
    """Any hashable ids as the whole numbers a model's inputs use, and back.

    Attributes:
        codes: the number given to each id, in order of first sight.
        names: (C,) the ids by number (kept as given: strings stay strings).
    """

    codes: dict[Hashable, int] = field(default_factory=dict)
    names: list[Hashable] = field(default_factory=list)

    def encode(self, ids: Sequence[Hashable] | np.ndarray, where: str) -> np.ndarray:
        """(N,) numbers of the (N,) ids, new ones numbered as they come; refuses an id that
        cannot be a key (unhashable) or appears twice."""
        out = np.empty(len(ids), dtype=np.int64)
        for i, name in enumerate(_plain(ids)):
            try:
                code = self.codes.get(name)
            except TypeError:
                raise GrouptronError(f"{where}: id {name!r} cannot name a person") from None
            if code is None:
                code = self.codes[name] = len(self.names)
                self.names.append(name)
            out[i] = code
        if len(np.unique(out)) != len(out):
            raise GrouptronError(f"{where}: an id appears twice in one update")
        return out

    def decode(self, codes: np.ndarray) -> np.ndarray:
        """(N,) the ids of (N,) numbers: numbers where every id given was a number, else the
        ids as given (an object array)."""
        names = [self.names[int(c)] for c in codes]
        if all(isinstance(n, int | float | np.integer | np.floating) for n in self.names):
            return np.asarray(names, dtype=np.float64)
        out = np.empty(len(names), dtype=object)
        out[:] = names
        return out


def _plain(ids: Sequence[Hashable] | np.ndarray) -> list[Hashable]:
    """Ids as plain Python values (NumPy scalars as ints, floats, strings)."""
    if isinstance(ids, np.ndarray):
        return [v.item() if isinstance(v, np.generic) else v for v in ids.tolist()]
    return [v.item() if isinstance(v, np.generic) else v for v in ids]


@dataclass
class LiveTracks:
    """The observations of the last ``window_s`` seconds, per person number.

    Attributes:
        window_s: how far back observations are kept.
        max_gap_s: observations further apart than this are not interpolated between.
        check_speed: restart a person's history at a sighting where no walker gets to from
            their last (a glitch, an id swap, a reused id: ``track_faults.unreachable``), as
            the frame-numbered session does.
    """

    window_s: float
    max_gap_s: float
    check_speed: bool = True
    time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    code: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    last_s: float | None = None

    def add(self, t_s: float, codes: np.ndarray, xy: np.ndarray) -> list[Any]:
        """Keep (N,) people's (N, 2) positions at ``t_s`` (after the last update's); returns
        the numbers whose history restarted where no walker gets to."""
        # The session judges clocks first (``track_faults.clock_step``): times only increase.
        assert self.last_s is None or t_s > self.last_s, (t_s, self.last_s)
        jumped = self._jumped(t_s, codes, xy) if self.check_speed else np.zeros(0, np.int64)
        keep = (self.time_s >= t_s - self.window_s) & ~np.isin(self.code, jumped)
        self.time_s = np.concatenate([self.time_s[keep], np.full(len(codes), t_s)])
        self.code = np.concatenate([self.code[keep], codes])
        self.xy = np.concatenate([self.xy[keep], xy])
        self.last_s = t_s
        return [int(c) for c in jumped]

    def _jumped(self, t_s: float, codes: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Numbers among ``codes`` seen last where no walker gets to by ``t_s``
        (``track_faults.unreachable``: their last velocity, an acceleration bound, and
        ``MAX_JUMP_SPEED_MPS``)."""
        if not len(self.code) or not len(codes):
            return np.zeros(0, dtype=np.int64)
        order = np.lexsort((self.time_s, self.code))
        last = np.append(self.code[order][1:] != self.code[order][:-1], True)
        last_code, last_t = self.code[order][last], self.time_s[order][last]
        last_xy = self.xy[order][last]
        at = np.clip(np.searchsorted(last_code, codes), 0, len(last_code) - 1)
        seen = last_code[at] == codes
        who, then_s, then_xy = codes[seen], last_t[at[seen]], last_xy[at[seen]]
        # The last velocity over one model step of track before the last sighting.
        before_xy, known = self.positions_at(who, then_s - VELOCITY_BASE_S)
        velocity = np.where(known[:, None], (then_xy - before_xy) / VELOCITY_BASE_S, np.nan)
        jumped: np.ndarray = who[unreachable(t_s - then_s, then_xy, velocity, xy[seen])]
        return jumped

    def positions_at(self, codes: np.ndarray, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Q, 2) positions of people ``codes`` at ``times_s`` ((Q,) each), interpolated
        between their two observations around each time, and (Q,) whether there were such
        observations at most ``max_gap_s`` apart (an observation at the time itself counts)."""
        order = np.lexsort((self.time_s, self.code))
        code, time, xy = self.code[order], self.time_s[order], self.xy[order]
        # One sorted axis: a person's times offset by their number times a span no window has.
        span = 2.0 * (self.window_s + 1.0) + 1.0
        base = float(time.min()) if len(time) else 0.0
        key = code * span + (time - base)
        wanted = codes * span + (times_s - base)
        # An observation within TIME_TOLERANCE_S of the time is at it (grid times carry
        # rounding: 1.2 - 3 x 0.4 is -2e-16, not the observation at 0).
        after = np.searchsorted(key, wanted - TIME_TOLERANCE_S, side="left")
        found = after < len(key)
        exact = np.zeros(len(codes), dtype=bool)
        safe = np.minimum(after, len(key) - 1)
        close = np.abs(time[safe[found]] - times_s[found]) <= TIME_TOLERANCE_S
        exact[found] = (code[safe[found]] == codes[found]) & close
        before = safe - 1
        bracket = found & (before >= 0) & ~exact
        bracket &= (code[np.maximum(before, 0)] == codes) & (code[safe] == codes)
        gap = time[safe] - time[np.maximum(before, 0)]
        bracket &= gap <= self.max_gap_s
        out = np.zeros((len(codes), 2))
        out[exact] = xy[safe[exact]]
        b, a = np.maximum(before[bracket], 0), safe[bracket]
        share = ((times_s[bracket] - time[b]) / np.maximum(time[a] - time[b], 1e-12))[:, None]
        out[bracket] = xy[b] + share * (xy[a] - xy[b])
        return out, exact | bracket

    def grid_rows(
        self, t_s: float, codes: np.ndarray, steps: int, dt_s: float, frames_per_step: int
    ) -> np.ndarray:
        """(R, 4) ``frame, number, x, y`` rows of ``codes``' positions on the grid
        ``t_s - j dt_s`` (j = 0 .. steps - 1), the frame of ``t_s`` being
        ``(steps - 1) * frames_per_step``; a grid point without observations around it is
        left out (the forecaster fills or restarts as for missed detections)."""
        j = np.arange(steps)
        query_code = np.repeat(codes, steps)
        query_t = t_s - np.tile(j, len(codes)) * dt_s
        xy, found = self.positions_at(query_code, query_t)
        frames = (steps - 1 - np.tile(j, len(codes))) * frames_per_step
        rows: np.ndarray = np.column_stack([frames, query_code, xy])[found]
        return rows[np.lexsort((rows[:, 0], rows[:, 1]))]
