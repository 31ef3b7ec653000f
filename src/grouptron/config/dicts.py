"""Settings to and from JSON-ready dicts: unknown keys refused with a guess, lists read as
tuples, one section laid over another."""

from __future__ import annotations

import dataclasses
import difflib
import json
import typing
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any, TypeVar

from grouptron.config.settings import (
    DataConfig,
    ExperimentConfig,
    GroupConfig,
    GroupEncoderConfig,
    LossConfig,
    ModelConfig,
    TrainConfig,
)
from grouptron.errors import GrouptronError
from grouptron.io import write_text_atomically

ConfigT = TypeVar("ConfigT")


def config_to_dict(config: Any) -> dict[str, Any]:
    """A JSON-ready dict of a (nested) config dataclass."""
    return json.loads(json.dumps(dataclasses.asdict(config)))


def config_from_dict(cls: type[ConfigT], values: dict[str, Any]) -> ConfigT:
    """Build ``cls`` from a dict, refusing unknown keys and converting lists to tuples."""
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls} is not a dataclass")
    if not isinstance(values, dict):
        raise GrouptronError(f"{cls.__name__} must be a table of settings, not {values!r:.40}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(str(k) for k in set(values) - set(fields))
    if unknown:
        hints = [difflib.get_close_matches(k, list(fields), n=1) for k in unknown]
        guesses = [
            f"{k} (did you mean {h[0]}?)" if h else k for k, h in zip(unknown, hints, strict=True)
        ]
        raise GrouptronError(f"unknown {cls.__name__} keys: {', '.join(guesses)}")
    kwargs: dict[str, Any] = {}
    types = typing.get_type_hints(cls)
    for name, value in values.items():
        field_type = fields[name].type
        nested = _NESTED.get(field_type) if isinstance(field_type, str) else None
        if nested is not None:
            if not isinstance(value, dict):
                raise GrouptronError(f"{cls.__name__}.{name} must be a table of settings")
            value = config_from_dict(nested, value)
        else:
            value = _typed(f"{cls.__name__}.{name}", types[name], value)
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise GrouptronError(f"invalid {cls.__name__}: {exc}") from None


def _typed(where: str, expected: Any, value: Any) -> Any:
    """``value`` as the field's type (ints accepted for floats, lists for tuples), or one line
    saying what was expected."""
    origin = typing.get_origin(expected)
    if origin is typing.Literal:
        if value not in typing.get_args(expected):
            choices = ", ".join(repr(a) for a in typing.get_args(expected))
            raise GrouptronError(f"{where} must be one of {choices}, not {value!r}")
        return value
    if origin is dict:
        if not isinstance(value, dict):
            raise GrouptronError(f"{where} must be a table of settings, not {value!r:.40}")
        return dict(value)
    if origin is tuple or expected is tuple:
        if not isinstance(value, list | tuple):
            raise GrouptronError(f"{where} must be a list, not {value!r}")
        return tuple(value)
    if expected is float and isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    if expected in (int, bool, str) and type(value) is not expected:
        raise GrouptronError(f"{where} must be {expected.__name__}, not {value!r}")
    return value


_NESTED: dict[str, type] = {
    "DataConfig": DataConfig,
    "GroupConfig": GroupConfig,
    "ModelConfig": ModelConfig,
    "GroupEncoderConfig": GroupEncoderConfig,
    "LossConfig": LossConfig,
    "TrainConfig": TrainConfig,
}


def _section_names() -> set[str]:
    """The settings of an experiment that are tables of their own (``train``, ``data``...)."""
    defaults = ExperimentConfig()
    return {f.name for f in fields(defaults) if is_dataclass(getattr(defaults, f.name))}


def merge_settings(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``overrides`` laid over it, section by section (nested dicts merge)."""
    merged = dict(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = merge_settings(merged[key], value)
        elif isinstance(merged.get(key), dict) or (isinstance(value, dict) and key in merged):
            # One side is a table, the other a single value: say which the settings expect.
            if key in _section_names():
                single = value if isinstance(merged.get(key), dict) else merged[key]
                why = f"must be a table of settings ({key}.NAME=VALUE), not {single!r}"
            else:
                why = f"is a single setting ({key}=VALUE), not a table"
            raise GrouptronError(f"settings: {key} {why}")
        else:
            merged[key] = value
    return merged


def load_config(cls: type[ConfigT], path: str | Path) -> ConfigT:
    """Read a config dataclass from a JSON file."""
    try:
        values = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise GrouptronError(f"{path}: cannot read config: {exc}") from None
    return config_from_dict(cls, values)


def save_config(config: Any, path: str | Path) -> None:
    """Write a config dataclass as indented JSON (atomically)."""
    write_text_atomically(Path(path), json.dumps(config_to_dict(config), indent=2) + "\n")


def non_default_settings(experiment: ExperimentConfig) -> dict[str, Any]:
    """``{"section.key": value}`` for every setting that differs from ExperimentConfig's
    defaults (split and model included), for model cards and ``config show --changes``."""
    return _differences(config_to_dict(experiment), config_to_dict(ExperimentConfig()), "")


def _differences(ours: dict[str, Any], base: dict[str, Any], prefix: str) -> dict[str, Any]:
    found: dict[str, Any] = {}
    for key, value in ours.items():
        if isinstance(value, dict):
            found.update(_differences(value, base.get(key, {}), f"{prefix}{key}."))
        elif base.get(key) != value:
            found[f"{prefix}{key}"] = value
    return found
