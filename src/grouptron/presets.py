"""Presets: the settings that make a named model out of another's code, and the few that
differ per (model, ETH/UCY split). Everything else is ExperimentConfig's defaults."""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from typing import Any

from grouptron.config import (
    ExperimentConfig,
    GroupConfig,
    config_from_dict,
    config_to_dict,
    merge_settings,
)
from grouptron.constants import CONSTANT_VELOCITY


@dataclass(frozen=True)
class ModelSpec:
    """A named model: the code it runs, the settings that make it, how reports show it.

    Attributes:
        name: what ``train --model`` and stored configurations call it.
        base: the network it runs: ``trajectron++`` (TrajectronCVAE) or ``grouptron``
            (GrouptronCVAE, with group- and scene-level encoders; it reads groups).
        display: its name in tables and on model cards.
        switches: the settings, by section, laid over ExperimentConfig's defaults.
        compared_with: the models (or ``constant-velocity``) reports subtract from it.
        paper: one of the paper's two models (the rest are this project's variants).
    """

    name: str
    base: str
    display: str
    switches: dict[str, dict[str, Any]] = field(default_factory=dict)
    compared_with: tuple[str, ...] = ()
    paper: bool = False

    @property
    def reads_groups(self) -> bool:
        """Whether its batches need the samples' groups (its network has group encoders)."""
        return self.base == "grouptron"


VARIANT_MODEL = "grouptron-robust"
"""The project's density-robust Grouptron (the settings below), beside the paper's two models."""
RESIDUAL_MODEL = "trajectron++-residual"
"""Trajectron++ whose decoder predicts velocities relative to the current one (below)."""
GROUP_RESIDUAL_MODEL = "grouptron-robust-residual"
"""``grouptron-robust`` with the velocity-residual decoder of ``trajectron++-residual``."""
CUSTOM = "custom"
"""What reports call a run whose switches match no named model."""

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
_RESIDUAL: dict[str, dict[str, Any]] = {"model": {"velocity_residual": True}}
_CV = CONSTANT_VELOCITY

MODELS: dict[str, ModelSpec] = {
    spec.name: spec
    for spec in (
        ModelSpec("trajectron++", "trajectron++", "Trajectron++", {}, (_CV,), paper=True),
        ModelSpec("grouptron", "grouptron", "Grouptron", {}, ("trajectron++", _CV), paper=True),
        ModelSpec(
            VARIANT_MODEL,
            "grouptron",
            "Grouptron (robust)",
            copy.deepcopy(_ROBUST_SWITCHES),
            ("trajectron++", "grouptron", _CV),
        ),
        ModelSpec(
            RESIDUAL_MODEL,
            "trajectron++",
            "Trajectron++ (residual)",
            copy.deepcopy(_RESIDUAL),
            ("trajectron++", _CV),
        ),
        ModelSpec(
            GROUP_RESIDUAL_MODEL,
            "grouptron",
            "Grouptron (robust, residual)",
            merge_settings(copy.deepcopy(_ROBUST_SWITCHES), _RESIDUAL),
            ("trajectron++", RESIDUAL_MODEL, VARIANT_MODEL, _CV),
        ),
    )
}
"""Every named model, the one list the others derive from. ``grouptron-robust`` is Grouptron
with every density switch on: E_scene sees all 8 observed steps, has dropout and layer norm and
leaves the ego out of its own group; groups are the detector's (single linkage cut at 1.5 m,
velocity-weighted) instead of C(N); neighbours and groups are averaged with log-count features
(README, "Grouptron"). ``trajectron++-residual`` is Trajectron++ whose decoder's velocity means
are offsets from the current velocity, so that an untrained or unsure decoder falls back to
walking on. ``grouptron-robust-residual`` has both."""

MODEL_NAMES = tuple(MODELS)
"""Every model ``train --model`` builds: the paper's two and the named variants."""
MODEL_PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    name: spec.switches for name, spec in MODELS.items() if spec.switches
}
"""Settings that make a named model out of another's code, by section."""
NAMED_MODEL_BASES = {name: spec.base for name, spec in MODELS.items() if not spec.paper}
"""The model whose code each named model runs with its preset's settings."""


def model_label(config: ExperimentConfig) -> str:
    """The named model a run is: the one on the same code whose switches it has (every
    setting any named model switches, compared; Trajectron++'s code reads the ``model``
    section alone), else ``custom``."""
    base = MODELS[config.model_name].base if config.model_name in MODELS else config.model_name
    read = ("model",) if base == "trajectron++" else ("model", "group_encoder", "groups")
    keys = {
        (section, key)
        for spec in MODELS.values()
        for section, table in spec.switches.items()
        for key in table
        if section in read
    }
    values, defaults = config_to_dict(config), config_to_dict(ExperimentConfig())
    for spec in MODELS.values():
        wanted = merge_settings(defaults, spec.switches)
        if spec.base == base and all(values[s][k] == wanted[s][k] for s, k in keys):
            return spec.name
    return CUSTOM


MODEL_SECTIONS = ("model", "group_encoder", "groups", "loss", "model_settings")
"""The settings that make a model what it is (training length, seed, precision and data do
not): where a run's switches match no named model, those of them that differ from its model's
preset name it."""


def run_label(config: ExperimentConfig) -> str:
    """The named model a run is (:func:`model_label`: by its switches; widths and the loss's
    weights do not make another model), else its model's name and the settings in which it
    differs from that model's preset on its split, of the sections its code reads
    (:data:`MODEL_SECTIONS`): ``trajectron++ [model.edge_aggregation="mean"]``; a model of the
    forecaster interface by its class and ``model_settings``."""
    label = model_label(config)
    if label != CUSTOM:
        return label
    preset = config_from_dict(
        ExperimentConfig, preset_values(config.split, config.model_name, config.dataset)
    )
    ours, theirs = config_to_dict(config), config_to_dict(preset)
    base = MODELS[config.model_name].base if config.model_name in MODELS else None
    read = {"trajectron++": ("model", "loss"), None: ("model_settings",)}  # what the code reads
    changed = [
        f"{section}.{key}={json.dumps(value)}"
        for section in read.get(base, MODEL_SECTIONS)
        for key, value in sorted(ours[section].items())
        if theirs[section].get(key) != value
    ]
    return f"{config.model_name} [{', '.join(changed)}]" if changed else config.model_name


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
"""The distance rule of ``grouptron groups detect`` (``--detector distance``, or any option of
the rule), of ``Forecast.group`` for a model that reads no groups and of ``plot``: single
linkage cut at 1.5 m, people at least
2 s times their velocity difference apart, groups of at most 6. Chosen on the four recordings
with human group labels (mean per-ego pair F1 0.774 against 0.612 for C(N)); 6 is the smallest
limit that changes no labelled partition, and it keeps a dense corridor crowd from being
chained into one group (docs/groups.md). The paper's model keeps C(N) (``GroupConfig()``)."""
LEARNED_LINK_PROBABILITY = 0.5
"""The learned detector links a pair it finds more likely companions than not (its
probabilities are the classes' shares, not reweighted: no threshold is tuned)."""
LEARNED_GROUPS = GroupConfig(
    linkage="single",
    max_distance_m=1.0 - LEARNED_LINK_PROBABILITY,
    max_group_size=6,
    detector="learned",
)
"""The default of ``groups detect`` and ``groups evaluate``: the shipped detector's links (with
its memory of pairs over the steps), groups of at most 6. Held out (each labelled recording
scored by a detector trained on the other three) its G-MITRE F1 is above T-DANTE's on all four
and above ``DETECTION_GROUPS``' on hotel and zara2, level on eth and zara1 (docs/groups.md).
The live path keeps the model's own rule: at 300 people this one costs several times the
3 ms that groups may take there."""


def describe_group_rule(groups: GroupConfig) -> str:
    """A few words naming the rule, e.g. ``single linkage, 1.5 m, 2 s x velocity``."""
    if groups.detector == "learned":
        size = "" if groups.max_group_size is None else f", at most {groups.max_group_size}"
        return f"learned detector{size}"
    if groups.max_distance_m is None:
        rule = "C(N) rule"
    else:
        rule = f"{groups.linkage} linkage, {groups.max_distance_m:g} m"
    if groups.velocity_weight_s > 0:
        rule += f", {groups.velocity_weight_s:g} s x velocity"
    if groups.max_group_size is not None:
        rule += f", at most {groups.max_group_size}"
    return rule
