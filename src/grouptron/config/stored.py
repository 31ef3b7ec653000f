"""Settings as a run stored them, read back today: older layouts and names migrated, and
settings added since given the values those runs used."""

from __future__ import annotations

from typing import Any

from grouptron.config.dicts import config_from_dict
from grouptron.config.settings import ExperimentConfig
from grouptron.errors import GrouptronError

STORED_DEFAULTS: dict[str, dict[str, Any]] = {
    "data": {"future_scale_m": 3.0, "backward_start": "next"}
}
"""Values of settings added after a run was stored, as that run used them: a stored
experiment without the keys was trained with these values, not with today's defaults. Both
keys arrived together, so a stored config that has ``future_scale_m`` without
``backward_start`` was trained with the strictly causal start (the default)."""

STORED_RENAMES: dict[str, dict[str, str]] = {"model": {"latent_modes": "latent_values"}}
"""Settings stored under an older name, by section: ``model.latent_modes`` is the number of
latent values Z ("mode" is what an evaluation scores)."""


def renamed_settings(values: dict[str, Any]) -> dict[str, Any]:
    """``values`` with every setting of :data:`STORED_RENAMES` under its name of today (a
    setting stored under both names is refused: which one holds is unknowable)."""
    upgraded = dict(values)
    for section, renames in STORED_RENAMES.items():
        stored = upgraded.get(section)
        if not isinstance(stored, dict) or not set(renames) & set(stored):
            continue
        stored = dict(stored)
        for old, new in renames.items():
            if old in stored:
                if new in stored:
                    raise GrouptronError(f"{section}.{old} and {section}.{new} are one setting")
                stored[new] = stored.pop(old)
        upgraded[section] = stored
    return upgraded


def experiment_from_stored(values: dict[str, Any]) -> ExperimentConfig:
    """An experiment read back from a checkpoint or run folder, older formats included."""
    if not isinstance(values, dict):
        raise GrouptronError(f"ExperimentConfig must be a table of settings, not {values!r:.40}")
    upgraded = renamed_settings(values)
    model = upgraded.get("model")
    if isinstance(model, dict) and ("group_dim" in model or "group_adjacency" in model):
        # Stored before the group encoders had a section of their own.
        model = dict(model)
        moved = {k: model.pop(k) for k in ("group_dim", "group_adjacency") if k in model}
        upgraded["model"] = model
        upgraded["group_encoder"] = {**moved, **upgraded.get("group_encoder", {})}
    for section, defaults in STORED_DEFAULTS.items():
        stored = upgraded.get(section, {})
        if isinstance(stored, dict) and not set(defaults) & set(stored):
            upgraded[section] = {**defaults, **stored}
    return config_from_dict(ExperimentConfig, upgraded)
