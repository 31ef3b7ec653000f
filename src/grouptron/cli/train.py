"""``grouptron train``: train a model on one split."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

import torch

from grouptron.cli.common import (
    CURVES,
    show_progress,
)
from grouptron.config import (
    ExperimentConfig,
    TrainConfig,
    config_from_dict,
    config_to_dict,
    merge_settings,
)
from grouptron.data.custom import read_dataset
from grouptron.errors import GrouptronError
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.checkpoint import load_checkpoint
from grouptron.presets import preset_values
from grouptron.training import distributed
from grouptron.training.metrics_log import MetricsWriter
from grouptron.training.precision import native_bf16, precision_name, resolve_precision
from grouptron.training.prepare import prepare_training_data
from grouptron.training.selection import SELECTION
from grouptron.training.trainer import LAST, train
from grouptron.viz.training import plot_training_curves


def _settings_file(path: str) -> dict[str, Any]:
    try:
        values = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise GrouptronError(f"{path}: cannot read config: {exc}") from None
    if not isinstance(values, dict):
        raise GrouptronError(f"{path}: a config file holds a table of settings")
    return values


def parse_setting(text: str) -> dict[str, Any]:
    """``"group_encoder.group_dim=32"`` -> ``{"group_encoder": {"group_dim": 32}}``; read as
    JSON where it parses (numbers, true/false, lists), else as a string."""
    key, sep, raw = text.partition("=")
    parts = key.strip().split(".")
    if not sep or not all(parts):
        raise GrouptronError(f"--set {text!r}: expected SECTION.KEY=VALUE, e.g. train.seed=3")
    try:
        value: Any = json.loads(raw)
    except json.JSONDecodeError:
        value = raw
    for part in reversed(parts):
        value = {part: value}
    return value


def _split_or_dataset(args: argparse.Namespace) -> tuple[str, str]:
    """(split, dataset): an ETH/UCY split, or a dataset of one's own named by its file."""
    dataset = getattr(args, "dataset", None)
    if (args.split is None) == (dataset is None):
        raise GrouptronError("give either --split (ETH/UCY) or --dataset FILE (your own)")
    if dataset is None:
        return args.split, ""
    description = read_dataset(dataset)
    return description.name, str(description.source)


INHERITED_DATA = ("frames_per_step", "on_gap", "min_history_train")
"""Data settings a fine-tuned run takes from its own data, not from the checkpoint it starts
from (the checkpoint's scales, horizons and derivatives define what its weights read)."""
DEFAULT_DERIVATIVES = "backward"
"""Causal: a model trained so forecasts live tracks as it was trained (README). The papers'
protocol is ``--derivatives central``."""


def _starting_point(init_from: str | None) -> tuple[dict[str, Any], str]:
    """The settings a run started from a checkpoint takes from it (its architecture, groups
    and input scales, derivatives included) and its model name; nothing without one."""
    if not init_from:
        return {}, ""
    stored = load_checkpoint(resolve_checkpoint(init_from)).config
    values = config_to_dict(stored)
    data = {k: v for k, v in values["data"].items() if k not in INHERITED_DATA}
    kept = {"data": data, **{k: values[k] for k in ("model", "group_encoder", "groups")}}
    return kept, stored.model_name


def experiment_from_args(
    args: argparse.Namespace, *, choose_precision: bool = True
) -> ExperimentConfig:
    """The run's configuration: the model's preset on the split, then what ``--init-from``'s
    checkpoint defines (architecture, groups, input scales, derivatives), then the --config
    file, then each --set, then the explicit flags (a later source wins). Derivatives default
    to causal (``DEFAULT_DERIVATIVES``) where none of these names them."""
    file_values = _settings_file(args.config) if args.config else {}
    started, started_model = _starting_point(args.init_from)
    model = args.model or file_values.get("model_name") or started_model or "trajectron++"
    split, dataset = _split_or_dataset(args)
    values = merge_settings(preset_values(split, model, dataset), started)
    values = merge_settings(values, file_values)
    sets = [parse_setting(text) for text in args.set or []]
    for setting in sets:
        values = merge_settings(values, setting)
    values = merge_settings(values, {"split": split, "model_name": model, "dataset": dataset})
    flags = {
        "epochs": args.epochs,
        "seed": args.seed,
        "batch_size": args.batch_size,
        "learning_rate": args.lr,
        "threads": args.threads,
        "init_from": str(resolve_checkpoint(args.init_from)) if args.init_from else None,
    }
    train_values = {k: v for k, v in flags.items() if v is not None}
    named = [started, file_values, *sets]
    derivatives = args.derivatives or (
        None if any("derivatives" in v.get("data", {}) for v in named) else DEFAULT_DERIVATIVES
    )
    data_values: dict[str, Any] = {"on_gap": args.on_gap}
    if derivatives:
        data_values["derivatives"] = derivatives
    values = merge_settings(values, {"train": train_values, "data": data_values})
    if args.precision is not None or ("bf16" not in values["train"] and choose_precision):
        threads = args.threads or TrainConfig().threads
        requested = args.precision or "auto"
        if requested == "auto" and native_bf16(args.device):
            print(
                "choosing the precision: timing bf16 autocast against fp32 on this CPU (about "
                "10 s; --precision fp32 or bf16 skips this)",
                flush=True,
            )
        bf16 = resolve_precision(requested, args.device, threads=threads)
        values = merge_settings(values, {"train": {"bf16": bf16}})
    return config_from_dict(ExperimentConfig, values)


def _resumed(args: argparse.Namespace, out: Path, asked: ExperimentConfig) -> ExperimentConfig:
    """A resumed run keeps its stored configuration; only its length, threads and (when
    given explicitly) precision may change."""
    stored = load_checkpoint(out / LAST).config
    if (stored.split, stored.model_name) != (asked.split, asked.model_name):
        raise GrouptronError(
            f"{out} holds a {stored.model_name} run on {stored.split}, not "
            f"{asked.model_name} on {asked.split}"
        )
    length: dict[str, Any] = {"epochs": asked.train.epochs, "threads": asked.train.threads}
    if args.precision is not None:
        length["bf16"] = asked.train.bf16
        if asked.train.bf16 != stored.train.bf16:
            print(
                f"note: {out} ran in {precision_name(stored.train.bf16)} so far; the "
                f"remaining epochs run in {precision_name(asked.train.bf16)} (each epoch's "
                "precision is in metrics.csv and on the model card)"
            )
    if args.epochs is None:
        length["epochs"] = stored.train.epochs
    if args.threads is None:
        length["threads"] = stored.train.threads
    return dataclasses.replace(stored, train=dataclasses.replace(stored.train, **length))


_SETTINGS = ("model", "config", "set", "derivatives", "init_from", "seed", "batch_size", "lr")
"""Options that define a run: a resumed run keeps its own."""


def _experiment_and_folder(args: argparse.Namespace) -> tuple[ExperimentConfig, Path]:
    """The run's configuration and output folder; ``--resume --out FOLDER`` alone continues
    the run there with its stored configuration (split or dataset, model and all)."""
    if args.resume and args.out and args.split is None and getattr(args, "dataset", None) is None:
        out = Path(args.out)
        given = [f"--{n.replace('_', '-')}" for n in _SETTINGS if getattr(args, n, None)]
        if given:
            raise GrouptronError(
                f"--resume continues {out} with its stored settings; {', '.join(given)} would "
                "be ignored (start a new run with --out elsewhere, or give --split to check)"
            )
        if not (out / LAST).exists():
            raise GrouptronError(f"{out}: no {LAST} to resume; give --split or --dataset to start")
        stored = load_checkpoint(out / LAST).config
        bf16 = stored.train.bf16
        if args.precision is not None:
            threads = args.threads or stored.train.threads
            bf16 = resolve_precision(args.precision, args.device, threads=threads)
        epochs, threads = args.epochs or stored.train.epochs, args.threads or stored.train.threads
        length: dict[str, Any] = {"epochs": epochs, "threads": threads, "bf16": bf16}
        asked = dataclasses.replace(stored, train=dataclasses.replace(stored.train, **length))
        return _resumed(args, out, asked), out
    experiment = experiment_from_args(args)
    name = f"{experiment.model_name}-{experiment.split}-{experiment.data.derivatives}"
    out = Path(args.out or f"runs/{name}")
    if args.resume and (out / LAST).exists():
        experiment = _resumed(args, out, experiment)
    return experiment, out


def _chosen(out: Path, best_subset_fde: float) -> str:
    """How best.safetensors was chosen, each score labelled by the samples it is on."""
    line = f"best per-epoch validation ML FDE {best_subset_fde:.3f} m (on the per-epoch subset)"
    selection = out / SELECTION
    if not selection.exists():  # the run stopped before its end-of-schedule choice
        return line
    chosen = json.loads(selection.read_text())
    return (
        f"{line}; best.safetensors is epoch {chosen['selected_epoch']}, chosen on the whole "
        f"validation part ({chosen['validation_samples']} samples): ML FDE "
        f"{chosen['full_val_ml_fde']:.3f} m, constant velocity {chosen['full_val_cv_fde']:.3f} m"
    )


def cmd_train(args: argparse.Namespace) -> int:
    """``grouptron train``: train a model (on several processes when launched by torchrun),
    then plot its training curves and say which checkpoint was chosen."""
    experiment, out = _experiment_and_folder(args)
    data = experiment.data
    prepared = prepare_training_data(
        experiment, args.data_dir, use_cache=not args.no_cache, announce=True
    )
    train_part, val_part = prepared.train, prepared.val
    cluster = distributed.start(torch.device(args.device))
    if cluster.is_main:
        processes = f", {cluster.world_size} processes" if cluster.distributed else ""
        print(
            f"training {experiment.model_name} on {experiment.split} ({data.derivatives} "
            "derivatives): "
            f"{len(train_part.samples)} training / {len(val_part.samples)} validation samples, "
            f"{experiment.train.epochs} epochs{processes} -> {out}"
        )
    try:
        state = train(
            experiment,
            train_part.samples,
            val_part.samples,
            out,
            resume=args.resume,
            progress=show_progress(args),
            train_groups=prepared.train_groups,
            val_groups=prepared.val_groups,
            device=args.device,
            cluster=cluster,
            train_weights=prepared.train_weights,
        )
    finally:
        distributed.stop(cluster)
    if cluster.is_main:
        records = MetricsWriter(out).records()
        if records:
            plot_training_curves(records, out.name, out / CURVES)
        chosen = (
            _chosen(out, state.best_val_fde)
            if len(val_part.samples)
            else ("no validation data: the last epoch is best.safetensors")
        )
        print(
            f"done: {state.epoch} epochs, {state.iteration} steps; {chosen}; checkpoints in {out}"
        )
    return 0
