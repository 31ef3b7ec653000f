"""A model card (README.md) beside every run's checkpoints, rewritten after every epoch.

It says what the weights are (model, split, derivatives), how they were trained (recipe, epochs,
wall time, machine) and how they did on validation, so a shipped checkpoint explains itself.
"""

from __future__ import annotations

import json
import math
import platform
import sys
from pathlib import Path
from typing import Any

import torch

from grouptron.config import ExperimentConfig, non_default_settings
from grouptron.constants import ALL_LOCATIONS
from grouptron.errors import GrouptronError
from grouptron.io import write_text_atomically
from grouptron.model.factory import DISPLAY_NAMES
from grouptron.model.forecaster import is_outside_name, outside_forecaster
from grouptron.presets import CUSTOM, model_label

CARD = "README.md"
DERIVATIVES_NOTES = {
    "central": "central derivatives (the papers' protocol; the last observed velocity uses "
    "the next position)",
    "backward": "backward derivatives (causal)",
}


def describe_device(device: torch.device, threads: int) -> str:
    """E.g. ``"cpu: AMD EPYC 7B13, 2 threads"`` or ``"cuda: NVIDIA H100 80GB HBM3"``."""
    if device.type == "cuda":
        return f"cuda: {torch.cuda.get_device_name(device)}"
    return f"{device.type}: {_cpu_name()}, {threads} threads"


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def _epochs_trained(last: dict[str, Any], warm_started: bool) -> str:
    steps = f"{last.get('iteration', 0)} optimiser steps"
    steps += ", counting the warm start's" if warm_started else ""
    return f"{last.get('epoch', 0)} ({steps})"


def _precision_ranges(records: list[dict[str, Any]]) -> str:
    """E.g. ``"fp32 (epochs 1-36), bf16 (epochs 37-100)"``; epochs logged before the
    precision was recorded ran in fp32 (bf16 was opt-in then and off in every shipped run)."""
    ranges: list[list[Any]] = []
    for record in records:
        name = record.get("precision", "fp32")
        if ranges and ranges[-1][0] == name:
            ranges[-1][2] = record["epoch"]
        else:
            ranges.append([name, record["epoch"], record["epoch"]])
    if len(ranges) == 1:
        return f"{ranges[0][0]} (all epochs)"
    return ", ".join(
        f"{n} (epochs {a}-{b})" if a != b else f"{n} (epoch {a})" for n, a, b in ranges
    )


def _selection_rows(
    scored: list[dict[str, Any]], selection: dict[str, Any] | None
) -> list[tuple[str, str]]:
    """How ``best.safetensors`` was chosen: on the whole validation part at the end of the
    schedule, or (while training) the best epoch on the per-epoch validation subset."""
    if selection is not None and not selection["validation_samples"]:
        return [
            (
                "selected",
                f"epoch {selection['selected_epoch']}, the last: no validation data (all "
                "locations trained on); in `best.safetensors`",
            ),
            ("validation ML ADE / FDE", "-"),
        ]
    if selection is not None:
        candidates = ", ".join(
            f"{c['epoch']}: {c['full_val_ml_fde']:.3f}" for c in selection["candidates"]
        )
        return [
            (
                "selected",
                f"epoch {selection['selected_epoch']}: best ML FDE on all "
                f"{selection['validation_samples']} validation samples among the epochs best on "
                f"the per-epoch subset (epoch: FDE m = {candidates}); test data never used; "
                "in `best.safetensors`",
            ),
            (
                "validation ML ADE / FDE",
                f"{selection['full_val_ml_ade']:.3f} / {selection['full_val_ml_fde']:.3f} m "
                f"(constant velocity on the same samples: {selection['full_val_cv_ade']:.3f} / "
                f"{selection['full_val_cv_fde']:.3f} m)",
            ),
        ]
    best = min(scored, key=lambda r: r["val_ml_fde"]) if scored else None
    if best is None:
        return [("selected", "no validation yet"), ("validation ML ADE / FDE", "-")]
    on = f"{best['val_samples']} validation samples" if "val_samples" in best else "validation"
    return [
        (
            "selected",
            f"epoch {best['epoch']} (best ML FDE on {on} so far; test data never used), in "
            "`best.safetensors`",
        ),
        (
            "validation ML ADE / FDE",
            f"{best['val_ml_ade']:.3f} / {best['val_ml_fde']:.3f} m (constant velocity on the "
            f"same samples: {best['val_cv_ade']:.3f} / {best['val_cv_fde']:.3f} m)",
        ),
    ]


def _settings(config: ExperimentConfig) -> str:
    """Every non-default setting, e.g. ``train.seed = 2``; the rest are ExperimentConfig's
    defaults (the reference recipe)."""
    changed = non_default_settings(config)
    return "; ".join(f"`{k} = {json.dumps(v)}`" for k, v in changed.items()) or "none"


def _wall_time(records: list[dict[str, Any]]) -> str:
    timed = [r["epoch_seconds"] for r in records if "epoch_seconds" in r]
    untimed = [r.get("train_seconds", 0.0) for r in records if "epoch_seconds" not in r]
    parts = []
    if timed:
        parts.append(f"{_minutes(sum(timed))} for {len(timed)} epochs (training and validation)")
    if untimed:
        parts.append(
            f"{_minutes(sum(untimed))} of optimiser steps for {len(untimed)} epochs whose "
            "whole-epoch time was not logged"
        )
    return "; ".join(parts) or "-"


def _model_name(config: ExperimentConfig) -> str:
    """The named model the run is, or its code's model with switches of its own, or a
    model of the forecaster interface by its class."""
    if is_outside_name(config.model_name):
        return f"`{config.model_name}` (a model of the forecaster interface, docs/models.md)"
    label = model_label(config)
    if label != CUSTOM:
        return DISPLAY_NAMES.get(label, label)
    shown = DISPLAY_NAMES.get(config.model_name, config.model_name)
    return f"{shown} with switches of its own ({CUSTOM}: see the settings below)"


def _architecture(config: ExperimentConfig) -> list[tuple[str, str]]:
    """A model of the forecaster interface's class and what its module says it is (its
    docstring's first paragraph); nothing for the shipped CVAEs (their settings say it)."""
    if not is_outside_name(config.model_name):
        return []
    try:
        found = outside_forecaster(config.model_name)
    except GrouptronError:  # a card is written wherever the class went since
        return [("architecture", "its class cannot be imported here")]
    module = sys.modules.get(found.__module__)
    text = ((module and module.__doc__) or found.__doc__ or "").strip().split("\n\n")[0]
    about = " ".join(text.split())
    return [("architecture", f"`{found.__module__}:{found.__qualname__}`: {about}")]


def _recipe(config: ExperimentConfig, records: list[dict[str, Any]]) -> str:
    train = config.train
    augmentation = "24-angle rotation augmentation, " if train.rotation_augmentation else ""
    recipe = (
        f"Adam {train.learning_rate:g}, decay {train.lr_decay_per_iter:g} per step, batch "
        f"{train.batch_size}, {augmentation}value clipping {train.grad_clip_value:g}, "
        f"seed {train.seed}; {train.epochs} epochs scheduled"
    )
    if train.init_from:
        kind = next((r["initialised_from"] for r in records if "initialised_from" in r), "")
        what = kind or "its weights, optimiser and step count"
        recipe += f"; started from `{train.init_from}` ({what})"
    return recipe


def render_model_card(
    name: str,
    config: ExperimentConfig,
    records: list[dict[str, Any]],
    selection: dict[str, Any] | None = None,
) -> str:
    """The card of a run from its configuration, per-epoch metric records and final
    selection (None until the schedule has finished)."""
    train = config.train
    scored = [r for r in records if not math.isnan(r.get("val_ml_fde", math.nan))]
    last = records[-1] if records else {}
    devices = ", ".join(dict.fromkeys(str(r["device"]) for r in records if "device" in r))
    data = (
        f"{config.split} (a dataset of your own, `{config.dataset}`)"
        if config.dataset
        else f"{config.split} (the train and val parts of all five locations; nothing held "
        "out, so its scores on ETH/UCY are not test scores: a model for use, never for "
        "benchmark tables)"
        if config.split == ALL_LOCATIONS
        else f"{config.split} (trained on the train parts of the other four locations, "
        "validated on their val parts)"
    )
    cvae_only = (
        []
        if is_outside_name(config.model_name)
        else [
            (
                "future encoder input",
                f"future positions relative to now / {config.data.future_scale_m:g} m",
            )
        ]
    )
    rows = [
        ("model", _model_name(config)),
        *_architecture(config),
        ("split" if not config.dataset else "dataset", data),
        ("derivatives", DERIVATIVES_NOTES.get(config.data.derivatives, config.data.derivatives)),
        ("recipe", _recipe(config, records)),
        ("epochs trained", _epochs_trained(last, bool(train.init_from))),
        *_selection_rows(scored, selection),
        ("precision", _precision_ranges(records) if records else "-"),
        *cvae_only,
        ("wall time", _wall_time(records)),
        ("machine", devices or "not recorded"),
        ("settings other than the defaults", _settings(config)),
    ]
    lines = [f"# {name}", "", "| | |", "|---|---|"]
    lines += [f"| {key} | {value} |" for key, value in rows]
    lines += [
        "",
        "`last.safetensors` holds the full training state: continue with "
        "`grouptron train --out <this folder> --resume --epochs N`. Per-epoch metrics: "
        "`metrics.csv`, `metrics.jsonl`.",
    ]
    return "\n".join(lines) + "\n"


def write_model_card(
    out_dir: Path,
    config: ExperimentConfig,
    records: list[dict[str, Any]],
    selection: dict[str, Any] | None = None,
) -> None:
    """Write the run's model card (``README.md``) into ``out_dir``, atomically."""
    card = render_model_card(out_dir.name, config, records, selection)
    write_text_atomically(out_dir / CARD, card)
