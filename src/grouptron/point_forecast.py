"""The name of a point forecast, parsed once: what the API, every command, configs,
calibration files, cards and the report mean by ``ml``, ``ml-argmax``, ``ml-topK`` or ``mean``.

    PointForecast.parse("ml-top10").latent_values(25)  # 10 latent values decoded
    str(PointForecast.parse("ml-top1"))               # "ml-argmax"
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from typing import Final, Literal

from grouptron.constants import EVALUATION_MODES
from grouptron.errors import GrouptronError

NAMED: Final = EVALUATION_MODES[:4]
"""The point forecasts with a name of their own; ``ml-topK`` is one for every K >= 2."""

OLDER_NAMES: Final = {"mixture-mode": "ml", "argmax-latent": "ml-argmax"}
"""Names some forecasts had before the vocabulary was unified: accepted with a warning."""

_TOP = re.compile(r"ml-top([1-9][0-9]*)")
_BEST_OF = re.compile(r"best-of-([1-9][0-9]*)")


@dataclass(frozen=True)
class PointForecast:
    """One trajectory per person, made from the model's latent values.

    Attributes:
        kind: ``ml``: per step the mode of the p(z|x)-weighted velocity mixture, integrated
            (the papers' most likely); ``mean``: the p(z|x)-weighted mean trajectory.
        top: ``ml`` of only the K most probable latent values (1: the most probable one's
            means, ``ml-argmax``); None: all of them.
    """

    kind: Literal["ml", "mean"] = "ml"
    top: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("ml", "mean"):
            raise GrouptronError(f"a point forecast is of kind ml or mean, not {self.kind!r}")
        if self.top is not None and (self.kind == "mean" or self.top < 1):
            raise GrouptronError("only ml takes the K >= 1 most probable latent values")

    @classmethod
    def parse(cls, name: str | PointForecast, option: str = "forecast") -> PointForecast:
        """The forecast ``name`` names (a ``PointForecast`` as it is); an older name with a
        warning; anything else is refused in one line naming ``option`` and the choices."""
        if isinstance(name, PointForecast):
            return name
        if isinstance(name, str) and name in OLDER_NAMES:
            warnings.warn(
                f"{option} {name!r} is now called {OLDER_NAMES[name]!r}", FutureWarning, 2
            )
            name = OLDER_NAMES[name]
        if name == "ml":
            return cls("ml")
        if name == "mean":
            return cls("mean")
        if name == "ml-argmax":
            return cls("ml", 1)
        match = _TOP.fullmatch(name) if isinstance(name, str) else None
        if match is None:
            raise GrouptronError(
                f"{option} must be one of {', '.join(NAMED)} or ml-topK (K = 2, 3, ...), "
                f"not {name!r}"
            )
        return cls("ml", int(match.group(1)))

    @property
    def name(self) -> str:
        """Its one printed name: ``ml``, ``mean``, ``ml-argmax`` (ml of one latent value) or
        ``ml-topK``."""
        if self.kind == "mean" or self.top is None:
            return self.kind
        return "ml-argmax" if self.top == 1 else f"ml-top{self.top}"

    def __str__(self) -> str:
        return self.name

    def latent_values(self, Z: int) -> int:
        """How many of a model's ``Z`` latent values it decodes (the most probable first)."""
        return Z if self.top is None else min(self.top, Z)

    def for_model(self, Z: int) -> PointForecast:
        """The same forecast as a model of ``Z`` latent values makes it: ``ml-topK`` with K of
        at least Z is ``ml`` (so ``ml-top10`` of a 10-value model is named ``ml``)."""
        if self.top is not None and self.top >= Z and self.top > 1:
            return PointForecast("ml")
        return self


def is_point_forecast(name: str) -> bool:
    """Whether ``name`` parses as a point forecast (older names excepted)."""
    return name in NAMED or name == "mean" or _TOP.fullmatch(name) is not None


def best_of_samples(name: str) -> int | None:
    """K of an evaluation mode ``best-of-K`` (the best of K sampled futures), else None."""
    match = _BEST_OF.fullmatch(name) if isinstance(name, str) else None
    return int(match.group(1)) if match is not None else None


def is_sampled_mode(name: str) -> bool:
    """Whether an evaluation mode draws futures (``best-of-K``, ``nll``): a model's only,
    seeded, and never made by constant velocity."""
    return name == "nll" or best_of_samples(name) is not None


def is_evaluation_mode(name: str) -> bool:
    """Whether ``evaluate`` scores ``name``: one of ``EVALUATION_MODES``, ``ml-topK`` (K >= 2)
    or ``best-of-K`` (K >= 1). A score is reported under the mode's name, so a forecast is
    named by its one name only (``ml-top1`` is ``ml-argmax``, and refused here as it always
    was; ``best-of-05`` is refused, ``best-of-5`` is its name)."""
    if name in EVALUATION_MODES or best_of_samples(name) is not None:
        return True
    return is_point_forecast(name) and PointForecast.parse(name).name == name
