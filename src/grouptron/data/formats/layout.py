"""How a recording is laid out (:class:`RecordingFormat`: columns, frame rate, units, gaps)
and what reading it gives (:class:`Recording`: ids, times in seconds, positions in metres)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np

from grouptron.constants import DT_S, FRAMES_PER_STEP, MAX_GAP_S, UNITS_M
from grouptron.data.formats.spelling import KEYWORDS, OptionSpelling
from grouptron.errors import GrouptronError

DEFAULT_COLUMNS = ("frame", "id", "x", "y")
ETH_UCY_FPS = FRAMES_PER_STEP / DT_S
"""The ETH/UCY convention: frame numbers on a 10-frame grid per 0.4 s step (25 per second)."""
IGNORED = {"-", "_", "skip", "z"}


@dataclass(frozen=True)
class RecordingFormat:
    """How a track file is laid out.

    Attributes:
        columns: the name of every column, in order: ``id``, ``x``, ``y`` and one time column,
            ``frame`` (frame numbers, with ``fps``) or ``t`` (seconds, any floats, e.g. Unix
            time); any other name (``z``, ``-``) marks a column that is ignored, as are
            columns past the named ones.
        fps: frames per second of a ``frame`` column (None: the ETH/UCY convention, 10 frames
            per 0.4 s step).
        units: of x and y: ``m``, ``cm`` or ``mm``.
        max_gap_s: a track with no observation for longer than this is split in two; shorter
            gaps are bridged by interpolation.
        check_speed: refuse recordings whose median walking speed is implausible.
        as_is: an ETH/UCY-style ``frame id x y`` file read as it is (no layout of its own was
            given): frames on the step grid, a missed step splits its track (or is refused),
            nothing is resampled; see :func:`read_table`.
        spelling: how messages name these options: as keywords (``max_gap_s``), or as the
            command line's flags (``--max-gap``) for a format the flags set.
    """

    columns: tuple[str, ...] = DEFAULT_COLUMNS
    fps: float | None = None
    units: str = "m"
    max_gap_s: float = MAX_GAP_S
    check_speed: bool = True
    as_is: bool = False
    spelling: OptionSpelling = field(default=KEYWORDS, compare=False, repr=False)

    def __post_init__(self) -> None:
        names = [c for c in self.columns if c not in IGNORED]
        columns, fps = self.spelling.setting("columns", ",".join(self.columns)), self.option("fps")
        for needed in ("id", "x", "y"):
            if names.count(needed) != 1:
                raise GrouptronError(f"{columns}: needs exactly one {needed!r} column")
        if ("frame" in names) == ("t" in names):
            raise GrouptronError(
                f"{columns}: needs one time column, 'frame' (frame numbers, with {fps}) or 't' "
                "(seconds)"
            )
        if self.fps is not None and "t" in names:
            raise GrouptronError(f"{fps} applies to a 'frame' column; a 't' column is in seconds")
        for name, value in (("fps", self.fps), ("max_gap_s", self.max_gap_s)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, Real)):
                raise GrouptronError(f"{self.option(name)} must be a number, not {value!r}")
        if self.fps is not None and not (math.isfinite(self.fps) and self.fps > 0):
            raise GrouptronError(f"{fps} must be a positive number, not {self.fps}")
        if self.units not in UNITS_M:
            raise GrouptronError(
                f"{self.option('units')} must be one of {', '.join(UNITS_M)}, not {self.units!r}"
            )
        if not self.max_gap_s > 0:
            raise GrouptronError(
                f"{self.option('max_gap_s')} must be positive (seconds), not {self.max_gap_s}"
            )

    def option(self, name: str) -> str:
        """An option's name as whoever set it writes it (``--max-gap`` or ``max_gap_s``)."""
        return self.spelling.name(name)

    @property
    def time_column(self) -> str:
        """The time column's name: ``t`` (seconds) or ``frame`` (frame numbers)."""
        return "t" if "t" in self.columns else "frame"

    @property
    def seconds_per_frame(self) -> float:
        """Seconds per frame number: ``1 / fps`` (ETH/UCY's 25 fps where ``fps`` is None)."""
        return 1.0 / (self.fps if self.fps is not None else ETH_UCY_FPS)


def parse_columns(text: str, spelling: OptionSpelling = KEYWORDS) -> tuple[str, ...]:
    """``"frame,id,x,y"`` (commas or spaces) -> ``("frame", "id", "x", "y")``."""
    names = tuple(n.strip().lower() for n in re.split(r"[,\s]+", text.strip()) if n.strip())
    if not names:
        example = spelling.setting("columns", "frame,id,x,y")
        raise GrouptronError(f"{spelling.name('columns')} is empty; e.g. {example}")
    return names


@dataclass(frozen=True)
class Recording:
    """Observations of one file: (R,) ids, (R,) times in seconds, (R, 2) positions in metres,
    (R,) the file line of every row (for error messages), and the seconds per frame number
    when times came from frame numbers (None for seconds)."""

    path: Path
    ped_id: np.ndarray
    time_s: np.ndarray
    pos_m: np.ndarray
    line: np.ndarray
    seconds_per_frame: float | None = None
    own_times: bool = False
    """Whether the file says itself how to read its times (TrajNet++'s fps, a bag's stamps),
    so that no time column of a layout can be misread."""
