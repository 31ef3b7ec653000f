"""A training run as a function: the run's configuration from a request (the flags of
``grouptron train``), its data, the loop, its curves and the line that says what was chosen.

    from grouptron.workflows.train import TrainRequest, train_run
    result = train_run(TrainRequest(split="univ", model="grouptron", epochs=100))
    print(result.summary, result.best)
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import torch

from grouptron.config import (
    ExperimentConfig,
    TrainConfig,
    config_from_dict,
    config_to_dict,
    merge_settings,
    renamed_settings,
)
from grouptron.data.datasets.custom import read_dataset
from grouptron.errors import GrouptronError
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.checkpoint import load_checkpoint
from grouptron.model.forecaster import is_outside_name, outside_forecaster
from grouptron.presets import preset_values
from grouptron.training import distributed
from grouptron.training.metrics_log import MetricsWriter
from grouptron.training.precision import (
    BF16_MIN_SPEEDUP,
    TIMED_ROUNDS,
    bf16_speedup_cpu,
    native_bf16,
    precision_name,
    resolve_precision,
)
from grouptron.training.prepare import prepare_training_data
from grouptron.training.selection import SELECTION
from grouptron.training.trainer import BEST, LAST, train
from grouptron.viz.training import plot_training_curves

CURVES = "curves.png"


@dataclass(frozen=True)
class TrainRequest:
    """What to train, as ``grouptron train``'s flags say it (None: the default or what a
    ``config`` file, ``init_from`` checkpoint or resumed run defines).

    Attributes:
        split: an ETH/UCY split (or ``all-locations``); or ``dataset``, a description file.
        model: a model name (``MODEL_NAMES``).
        out: the run folder (default ``runs/MODEL-SPLIT-DERIVATIVES``).
        resume: continue the run in ``out`` (``out`` alone is enough).
        init_from: start from a checkpoint (a shipped name or a file).
        config: a JSON file of settings laid over the model's preset.
        settings: ``SECTION.KEY=VALUE`` settings, applied after ``config``.
        precision: ``auto``, ``fp32`` or ``bf16`` (None: ``auto``, or what the run had).
        data_dir: the ETH/UCY folder (None: ``$GROUPTRON_DATA``, else the download cache).
        use_cache: read and keep samples and groups in the cache.
    """

    split: str | None = None
    dataset: str | None = None
    model: str | None = None
    epochs: int | None = None
    out: str | None = None
    resume: bool = False
    init_from: str | None = None
    config: str | None = None
    settings: tuple[str, ...] = ()
    seed: int | None = None
    batch_size: int | None = None
    lr: float | None = None
    threads: int | None = None
    precision: str | None = None
    device: str | torch.device = "cpu"
    derivatives: str | None = None
    on_gap: Literal["split", "error"] = "split"
    data_dir: str | None = None
    use_cache: bool = True


@dataclass(frozen=True)
class TrainResult:
    """A finished (or stopped) run: its folder, epochs and steps, and what was chosen."""

    out: Path
    epochs: int
    steps: int
    summary: str

    @property
    def best(self) -> Path:
        """The chosen weights (``best.safetensors``)."""
        return self.out / BEST


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


def _split_or_dataset(request: TrainRequest) -> tuple[str, str]:
    """(split, dataset): an ETH/UCY split, or a dataset of one's own named by its file."""
    split, dataset = request.split, request.dataset
    if (split is None) == (dataset is None):
        raise GrouptronError("give either --split (ETH/UCY) or --dataset FILE (your own)")
    if split is not None:
        return split, ""
    description = read_dataset(str(dataset))
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


def make_experiment(request: TrainRequest, *, choose_precision: bool = True) -> ExperimentConfig:
    """The run's configuration: the model's preset on the split, then what ``--init-from``'s
    checkpoint defines (architecture, groups, input scales, derivatives), then the --config
    file, then each --set, then the explicit flags (a later source wins). Derivatives default
    to causal (``DEFAULT_DERIVATIVES``) where none of these names them."""
    file_values = _settings_file(request.config) if request.config else {}
    started, started_model = _starting_point(request.init_from)
    model = request.model or file_values.get("model_name") or started_model or "trajectron++"
    if is_outside_name(model):
        outside_forecaster(model)  # a name that names nothing fails here, before any work
    split, dataset = _split_or_dataset(request)
    values = merge_settings(preset_values(split, model, dataset), started)
    values = merge_settings(values, renamed_settings(file_values))  # an older file's names
    sets = [renamed_settings(parse_setting(text)) for text in request.settings]
    for setting in sets:
        values = merge_settings(values, setting)
    values = merge_settings(values, {"split": split, "model_name": model, "dataset": dataset})
    flags = {
        "epochs": request.epochs,
        "seed": request.seed,
        "batch_size": request.batch_size,
        "learning_rate": request.lr,
        "threads": request.threads,
        "init_from": str(resolve_checkpoint(request.init_from)) if request.init_from else None,
    }
    train_values = {k: v for k, v in flags.items() if v is not None}
    named = [started, file_values, *sets]
    derivatives = request.derivatives or (
        None if any("derivatives" in v.get("data", {}) for v in named) else DEFAULT_DERIVATIVES
    )
    data_values: dict[str, Any] = {"on_gap": request.on_gap}
    if derivatives:
        data_values["derivatives"] = derivatives
    values = merge_settings(values, {"train": train_values, "data": data_values})
    if request.precision is not None or ("bf16" not in values["train"] and choose_precision):
        bf16 = _precision(request, outside=is_outside_name(model))
        values = merge_settings(values, {"train": {"bf16": bf16}})
    return config_from_dict(ExperimentConfig, values)


def _precision(request: TrainRequest, *, outside: bool) -> bool:
    """Whether the run trains in bf16: as asked, or for ``auto`` as measured here (the
    measurement printed with the choice). A model of the forecaster interface decides its
    own arithmetic: ``auto`` leaves it fp32 and ``bf16`` sets ``train.bf16`` for it to read."""
    requested, device = request.precision or "auto", torch.device(request.device)
    if requested == "auto" and outside:
        print("precision: fp32 (a model of the forecaster interface chooses its own)")
        return False
    if requested == "auto" and device.type == "cpu" and not native_bf16(device):
        print("precision: fp32 (this CPU computes bf16 only by emulation, about 10x slower)")
        return False
    if requested != "auto" or device.type != "cpu":
        return resolve_precision(requested, device)
    threads = request.threads or TrainConfig().threads
    print(
        "choosing the precision: timing bf16 autocast against fp32 on this CPU (a few "
        "seconds; --precision fp32 or bf16 skips this)",
        flush=True,
    )
    bf16 = resolve_precision(requested, device, threads=threads)
    speedup = bf16_speedup_cpu(threads)
    print(
        f"precision: {precision_name(bf16)} (bf16 autocast ran the decoder {speedup:.2f}x as "
        f"fast as fp32 here, median of {TIMED_ROUNDS} paired timings; bf16 needs "
        f"{BF16_MIN_SPEEDUP}x)",
        flush=True,
    )
    return bf16


def _resumed(request: TrainRequest, out: Path, asked: ExperimentConfig) -> ExperimentConfig:
    """A resumed run keeps its stored configuration; only its length, threads and (when
    given explicitly) precision may change."""
    stored = load_checkpoint(out / LAST).config
    if (stored.split, stored.model_name) != (asked.split, asked.model_name):
        raise GrouptronError(
            f"{out} holds a {stored.model_name} run on {stored.split}, not "
            f"{asked.model_name} on {asked.split}"
        )
    length: dict[str, Any] = {"epochs": asked.train.epochs, "threads": asked.train.threads}
    if request.precision is not None:
        length["bf16"] = asked.train.bf16
        if asked.train.bf16 != stored.train.bf16:
            print(
                f"note: {out} ran in {precision_name(stored.train.bf16)} so far; the "
                f"remaining epochs run in {precision_name(asked.train.bf16)} (each epoch's "
                "precision is in metrics.csv and on the model card)"
            )
    if request.epochs is None:
        length["epochs"] = stored.train.epochs
    if request.threads is None:
        length["threads"] = stored.train.threads
    return dataclasses.replace(stored, train=dataclasses.replace(stored.train, **length))


_SETTINGS = ("model", "config", "settings", "derivatives", "init_from", "seed", "batch_size", "lr")
"""Options that define a run: a resumed run keeps its own."""


def experiment_and_folder(request: TrainRequest) -> tuple[ExperimentConfig, Path]:
    """The run's configuration and output folder; ``--resume --out FOLDER`` alone continues
    the run there with its stored configuration (split or dataset, model and all)."""
    if request.resume and request.out and request.split is None and request.dataset is None:
        out = Path(request.out)
        given = [_flag(n) for n in _SETTINGS if getattr(request, n)]
        if given:
            raise GrouptronError(
                f"--resume continues {out} with its stored settings; {', '.join(given)} would "
                "be ignored (start a new run with --out elsewhere, or give --split to check)"
            )
        if not (out / LAST).exists():
            raise GrouptronError(f"{out}: no {LAST} to resume; give --split or --dataset to start")
        stored = load_checkpoint(out / LAST).config
        bf16 = stored.train.bf16
        if request.precision is not None:
            threads = request.threads or stored.train.threads
            bf16 = resolve_precision(
                request.precision, torch.device(request.device), threads=threads
            )
        epochs, threads = (
            request.epochs or stored.train.epochs,
            request.threads or stored.train.threads,
        )
        length: dict[str, Any] = {"epochs": epochs, "threads": threads, "bf16": bf16}
        asked = dataclasses.replace(stored, train=dataclasses.replace(stored.train, **length))
        return _resumed(request, out, asked), out
    experiment = make_experiment(request)
    model = experiment.model_name.replace(":", ".")  # a class's name as a folder's
    name = f"{model}-{experiment.split}-{experiment.data.derivatives}"
    out = Path(request.out or f"runs/{name}")
    if request.resume and (out / LAST).exists():
        experiment = _resumed(request, out, experiment)
    return experiment, out


def _flag(name: str) -> str:
    """A request field as ``grouptron train`` spells its flag."""
    return "--set" if name == "settings" else f"--{name.replace('_', '-')}"


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


def train_run(
    request: TrainRequest, *, progress: bool = True, announce: bool = True
) -> TrainResult:
    """Train as ``request`` says (on several processes when launched by torchrun), then plot
    the training curves; the result says which checkpoint was chosen. ``progress``: a bar on
    a terminal, else a line every half minute, and a line per epoch (False: silent);
    ``announce``: print what is trained on how many samples before the work."""
    experiment, out = experiment_and_folder(request)
    data = experiment.data
    prepared = prepare_training_data(
        experiment, request.data_dir, use_cache=request.use_cache, announce=announce
    )
    cluster = distributed.start(torch.device(request.device))
    if cluster.is_main and announce:
        processes = f", {cluster.world_size} processes" if cluster.distributed else ""
        print(
            f"training {experiment.model_name} on {experiment.split} ({data.derivatives} "
            f"derivatives): {len(prepared.train.samples)} training / "
            f"{len(prepared.val.samples)} validation samples, {experiment.train.epochs} "
            f"epochs{processes} -> {out}"
        )
    try:
        state = train(
            experiment,
            prepared.train.samples,
            prepared.val.samples,
            out,
            resume=request.resume,
            progress=progress,
            train_groups=prepared.train_groups,
            val_groups=prepared.val_groups,
            device=request.device,
            cluster=cluster,
            train_weights=prepared.train_weights,
        )
    finally:
        distributed.stop(cluster)
    if not cluster.is_main:
        return TrainResult(out, state.epoch, state.iteration, "")
    records = MetricsWriter(out).records()
    if records:
        plot_training_curves(records, out.name, out / CURVES)
    chosen = (
        _chosen(out, state.best_val_fde)
        if len(prepared.val.samples)
        else "no validation data: the last epoch is best.safetensors"
    )
    summary = f"done: {state.epoch} epochs, {state.iteration} steps; {chosen}; checkpoints in {out}"
    return TrainResult(out, state.epoch, state.iteration, summary)
