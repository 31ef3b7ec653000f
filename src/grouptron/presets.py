"""Presets: the settings that make a named model out of another's code, and the few that
differ per (model, ETH/UCY split). Everything else is ExperimentConfig's defaults."""

from __future__ import annotations

import copy
from typing import Any

from grouptron.config import ExperimentConfig, GroupConfig, config_from_dict, merge_settings

VARIANT_MODEL = "grouptron-robust"
"""The project's density-robust Grouptron (the settings below), beside the paper's two models."""
RESIDUAL_MODEL = "trajectron++-residual"
"""Trajectron++ whose decoder predicts velocities relative to the current one (below)."""
GROUP_RESIDUAL_MODEL = "grouptron-robust-residual"
"""``grouptron-robust`` with the velocity-residual decoder of ``trajectron++-residual``."""
MODEL_NAMES = ("trajectron++", "grouptron", VARIANT_MODEL, RESIDUAL_MODEL, GROUP_RESIDUAL_MODEL)
"""Every model ``train --model`` builds: the paper's two and the named variants."""

_ROBUST_SWITCHES: dict[str, dict[str, Any]] = {
    "groups": {"linkage": "single", "max_distance_m": 1.5, "velocity_weight_s": 2.0},
    "model": {"edge_aggregation": "mean", "edge_count_feature": True},
    "group_encoder": {
        "temporal_layers": 3,
        "scene_dropout_keep": 0.75,
        "scene_layer_norm": True,
        "ego_in_own_group": False,
        "count_feature": True,
    },
}

MODEL_PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    VARIANT_MODEL: copy.deepcopy(_ROBUST_SWITCHES),
    RESIDUAL_MODEL: {"model": {"velocity_residual": True}},
    GROUP_RESIDUAL_MODEL: merge_settings(
        copy.deepcopy(_ROBUST_SWITCHES), {"model": {"velocity_residual": True}}
    ),
}
"""Settings that make a named model out of another's code, by section, on every split and
dataset. ``grouptron-robust`` is Grouptron with every density switch on: E_scene sees all 8
observed steps, has dropout and layer norm and leaves the ego out of its own group; groups are
the detector's (single linkage cut at 1.5 m, velocity-weighted) instead of C(N); neighbours and
groups are averaged with log-count features (README, "Grouptron"). ``trajectron++-residual``
is Trajectron++ whose decoder's velocity means are offsets from the current velocity, so that
an untrained or unsure decoder falls back to walking on (README, "Grouptron", its variants).
``grouptron-robust-residual`` has both."""

NAMED_MODEL_BASES = {
    VARIANT_MODEL: "grouptron",
    RESIDUAL_MODEL: "trajectron++",
    GROUP_RESIDUAL_MODEL: "grouptron",
}
"""The model whose code each named model runs with its preset's settings."""

SPLIT_PRESETS: dict[tuple[str, str], dict[str, dict[str, Any]]] = {
    ("grouptron", "eth"): {"group_encoder": {"group_dim": 8}},
}
"""Settings that differ per (model, ETH/UCY split), by section, for a paper model and every
named model built on its code: the paper narrows Grouptron's ST-GCNs to 8 on eth, whose test
recording rarely has 5 or more people in view. Nothing else (no other model, no dataset of
one's own) gets a preset."""


def preset_values(split: str, model_name: str, dataset: str = "") -> dict[str, Any]:
    """The presets of a model and of a (model, ETH/UCY split) as nested settings; a dataset
    of one's own (``dataset`` given) gets the model's but no split's, whatever its name."""
    values: dict[str, Any] = {"split": split, "model_name": model_name, "dataset": dataset}
    values = merge_settings(values, MODEL_PRESETS.get(model_name, {}))
    if not dataset:
        base = NAMED_MODEL_BASES.get(model_name, model_name)
        values = merge_settings(values, SPLIT_PRESETS.get((base, split), {}))
    return values


def experiment_preset(split: str, model_name: str = "trajectron++") -> ExperimentConfig:
    """The default experiment of a model on a split, with its preset."""
    return config_from_dict(ExperimentConfig, preset_values(split, model_name))


DETECTION_GROUPS = GroupConfig(
    linkage="single", max_distance_m=1.5, velocity_weight_s=2.0, max_group_size=6
)
"""The groups ``grouptron groups detect`` finds: single linkage cut at 1.5 m, people at least
2 s times their velocity difference apart, groups of at most 6. Chosen on the four recordings
with human group labels (mean per-ego pair F1 0.774 against 0.612 for C(N)); 6 is the smallest
limit that changes no labelled partition, and it keeps a dense corridor crowd from being
chained into one group (docs/groups.md). The paper's model keeps C(N) (``GroupConfig()``)."""


def describe_group_rule(groups: GroupConfig) -> str:
    """A few words naming the rule, e.g. ``single linkage, 1.5 m, 2 s x velocity``."""
    if groups.max_distance_m is None:
        rule = "C(N) rule"
    else:
        rule = f"{groups.linkage} linkage, {groups.max_distance_m:g} m"
    if groups.velocity_weight_s > 0:
        rule += f", {groups.velocity_weight_s:g} s x velocity"
    if groups.max_group_size is not None:
        rule += f", at most {groups.max_group_size}"
    return rule
