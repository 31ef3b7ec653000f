"""What the node tells ``/diagnostics``: how old its forecasts are, how many inputs it did not
forecast and why, and a level a robot's monitor can act on (no graph here: a plain class).

Levels (``diagnostic_msgs/msg/DiagnosticStatus``):

- **ERROR** while inputs have been refused (malformed, in a moving frame, late) for more than
  ``REFUSED_ERROR_S`` with no forecast since: whatever the planner holds is getting old.
- **WARN** when the last forecast left more than ``AGE_WARN_RATIO`` times the median update
  time after its input arrived (the node falls behind its input), when an input was refused
  since the last forecast, or when no input came for ``SILENT_WARN_S``.
- **OK** otherwise; **STALE** in the last message of a node that stops.
"""

from __future__ import annotations

import statistics
from collections import deque
from dataclasses import dataclass, field

OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""``diagnostic_msgs/msg/DiagnosticStatus`` levels."""

REFUSED_ERROR_S = 1.0
"""Inputs refused this long, with no forecast since, make the status ERROR."""
AGE_WARN_RATIO = 2.0
"""A forecast older than this many median update times at publishing makes the status WARN."""
SILENT_WARN_S = 5.0
"""No input for this long (after the first) makes the status WARN."""
RECENT_UPDATES = 50
"""The median update time is over this many of the last updates."""


@dataclass(frozen=True)
class Status:
    """One diagnostic status: its level, a short message and the key/value pairs."""

    level: int
    message: str
    values: dict[str, str]


@dataclass
class Health:
    """Counts and timings of a live node, updated as inputs arrive and forecasts leave.

    Times are seconds of one monotonic clock the caller chooses (``now_s`` arguments).

    Attributes:
        received: inputs taken from the topic.
        forecast: inputs forecast and published.
        skipped: inputs never forecast because a newer one replaced them first, in the
            middleware's queue (gaps in the publisher's sequence numbers) or the node's.
        refused: inputs refused, by kind (``malformed``, ``late``, ...).
    """

    received: int = 0
    forecast: int = 0
    skipped: int = 0
    refused: dict[str, int] = field(default_factory=dict)
    update_ms: deque[float] = field(default_factory=lambda: deque(maxlen=RECENT_UPDATES))
    age_from_arrival_ms: float | None = None
    age_from_stamp_ms: float | None = None
    last_input_s: float | None = None
    refusing_since_s: float | None = None
    last_refusal: str = ""
    last_kind: str = ""
    _sequence: int | None = None

    def received_input(self, now_s: float, sequence: int | None = None) -> None:
        """An input was taken; ``sequence`` its publication sequence number (None: the
        middleware gives none), whose gaps count the inputs the middleware replaced."""
        self.received += 1
        self.last_input_s = now_s
        if sequence is not None:
            if self._sequence is not None and sequence > self._sequence + 1:
                self.skipped += sequence - self._sequence - 1
            # Numbers going back: another publisher, or the same one restarted; count anew.
            self._sequence = sequence

    def replaced(self) -> None:
        """An input taken but replaced by a newer one before it was forecast."""
        self.skipped += 1

    def set_aside(self, kind: str) -> None:
        """An input not forecast by choice (``kind``: ``inactive``, a lifecycle node's), counted
        without making the status an error."""
        self.refused[kind] = self.refused.get(kind, 0) + 1

    def refused_input(self, kind: str, reason: str, now_s: float) -> None:
        """An input refused (``kind``: malformed, late, ...; ``reason``: one line)."""
        self.refused[kind] = self.refused.get(kind, 0) + 1
        self.last_refusal, self.last_kind = reason, kind
        if self.refusing_since_s is None:
            self.refusing_since_s = now_s

    def published(
        self, update_ms: float, age_from_arrival_ms: float, age_from_stamp_ms: float
    ) -> None:
        """A forecast left: its update's time, and its age at publishing, from the input's
        arrival (wall clock) and from its stamp (the node's clock)."""
        self.forecast += 1
        self.update_ms.append(update_ms)
        self.age_from_arrival_ms = age_from_arrival_ms
        self.age_from_stamp_ms = age_from_stamp_ms
        self.refusing_since_s = None

    @property
    def not_forecast(self) -> int:
        """Inputs that got no forecast: skipped and refused."""
        return self.skipped + sum(self.refused.values())

    def status(self, now_s: float, stopped: bool = False) -> Status:
        """The level, message and values at ``now_s`` (module docstring)."""
        median = statistics.median(self.update_ms) if self.update_ms else None
        values = {
            "update time ms": _ms(self.update_ms[-1] if self.update_ms else None),
            "median update time ms": _ms(median),
            "age from arrival ms": _ms(self.age_from_arrival_ms),
            "age from stamp ms": _ms(self.age_from_stamp_ms),
            "received inputs": str(self.received),
            "forecast inputs": str(self.forecast),
            "not forecast inputs": str(self.not_forecast),
            "skipped inputs": str(self.skipped),
            **{f"{kind} inputs": str(n) for kind, n in sorted(self.refused.items())},
        }
        if stopped:
            return Status(STALE, "stopped", values)
        if self.refusing_since_s is not None and now_s - self.refusing_since_s > REFUSED_ERROR_S:
            since = now_s - self.refusing_since_s
            return Status(ERROR, f"inputs refused for {since:.1f} s: {self.last_refusal}", values)
        if self.refusing_since_s is not None:
            return Status(WARN, f"an input refused: {self.last_refusal}", values)
        age = self.age_from_arrival_ms
        if median is not None and age is not None and age > AGE_WARN_RATIO * median:
            return Status(WARN, f"forecasts {age:.0f} ms after their input: falling behind", values)
        if self.last_input_s is not None and now_s - self.last_input_s > SILENT_WARN_S:
            return Status(WARN, f"no input for {now_s - self.last_input_s:.0f} s", values)
        return Status(OK, "forecasting" if self.forecast else "waiting for input", values)


def _ms(value: float | None) -> str:
    return "" if value is None else f"{value:.1f}"
