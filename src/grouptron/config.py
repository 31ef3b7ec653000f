"""Typed, frozen configuration dataclasses; round-trip to JSON with errors on unknown keys."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar

from grouptron.data import constants
from grouptron.errors import GrouptronError
from grouptron.geometry import DERIVATIVE_SCHEMES, DerivativeScheme


@dataclass(frozen=True)
class DataConfig:
    """How raw tracks become samples (SPEC section 2). Defaults are the reference protocol."""

    derivatives: DerivativeScheme = "central"
    dt_s: float = constants.DT_S
    frames_per_step: int = constants.FRAMES_PER_STEP
    history_steps: int = constants.HISTORY_STEPS
    horizon_steps: int = constants.HORIZON_STEPS
    min_history_train: int = 2
    """Observed points (t-1, t) a training/validation sample needs; test samples need all 8."""
    perception_radius_m: float = constants.PERCEPTION_RADIUS_M
    edge_ramp_weights: tuple[float, ...] = constants.EDGE_RAMP_WEIGHTS
    position_scale_m: float = 3.0
    velocity_scale_mps: float = 2.0
    acceleration_scale_mps2: float = 1.0
    on_gap: Literal["split", "error"] = "split"

    def __post_init__(self) -> None:
        if self.derivatives not in DERIVATIVE_SCHEMES:
            raise GrouptronError(
                f"derivatives must be one of {', '.join(DERIVATIVE_SCHEMES)}, "
                f"not {self.derivatives!r}"
            )
        if self.on_gap not in ("split", "error"):
            raise GrouptronError(f"on_gap must be 'split' or 'error', not {self.on_gap!r}")
        if not 2 <= self.min_history_train <= self.history_steps:
            raise GrouptronError("min_history_train must be between 2 and history_steps")
        if self.history_steps < 2 or self.horizon_steps < 1:
            raise GrouptronError("history_steps must be >= 2 and horizon_steps >= 1")

    @property
    def state_scale(self) -> tuple[float, ...]:
        """Divisors of the 6 state components (x, y, vx, vy, ax, ay) in standardisation."""
        p, v, a = self.position_scale_m, self.velocity_scale_mps, self.acceleration_scale_mps2
        return (p, p, v, v, a, a)


ConfigT = TypeVar("ConfigT")


def config_to_dict(config: Any) -> dict[str, Any]:
    """A JSON-ready dict of a (nested) config dataclass."""
    return json.loads(json.dumps(dataclasses.asdict(config)))


def config_from_dict(cls: type[ConfigT], values: dict[str, Any]) -> ConfigT:
    """Build ``cls`` from a dict, refusing unknown keys and converting lists to tuples."""
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls} is not a dataclass")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise GrouptronError(f"unknown {cls.__name__} keys: {', '.join(unknown)}")
    kwargs: dict[str, Any] = {}
    for name, value in values.items():
        default = getattr(cls, name, None)
        if dataclasses.is_dataclass(default) and isinstance(value, dict):
            value = config_from_dict(type(default), value)
        elif isinstance(value, list):
            value = tuple(value)
        kwargs[name] = value
    return cls(**kwargs)


def load_config(cls: type[ConfigT], path: str | Path) -> ConfigT:
    """Read a config dataclass from a JSON file."""
    try:
        values = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise GrouptronError(f"{path}: cannot read config: {exc}") from None
    return config_from_dict(cls, values)


def save_config(config: Any, path: str | Path) -> None:
    """Write a config dataclass as indented JSON."""
    Path(path).write_text(json.dumps(config_to_dict(config), indent=2) + "\n")
