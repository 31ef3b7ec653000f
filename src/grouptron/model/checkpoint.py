"""Checkpoints: plain tensors in safetensors plus JSON (config, counters, RNG), never pickle.

One file holds everything so that it can be written atomically (temporary file + rename):
tensors under ``model.``, ``optim.`` and ``rng.`` prefixes, and the JSON documents in the
safetensors header's string metadata. A weights-only file (for shipping) has just ``model.``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError, safe_open
from safetensors.torch import load_file, save_file

from grouptron.config import ExperimentConfig, config_to_dict, experiment_from_stored
from grouptron.errors import GrouptronError
from grouptron.io import save_atomically
from grouptron.model.factory import build_model, load_weights
from grouptron.model.forecaster import Forecaster

FORMAT_VERSION = 1
BEST_WEIGHTS_FILE = "best.safetensors"
"""The selected weights of a run folder: what every command loads from ``<run>/``."""
TEMPORARY_CHECKPOINTS = ".*.safetensors.*.tmp"
"""Glob of the temporary files :func:`save_checkpoint` renames into place."""
FORMAT_NAME = "grouptron-checkpoint"


@dataclass
class Checkpoint:
    """The content of a checkpoint file.

    Attributes:
        config: the experiment the weights belong to.
        model_state: the model's tensors.
        epoch: completed epochs.
        iteration: completed optimiser steps.
        optimizer_state: Adam's state dict, or None for a weights-only file.
        extra: JSON-ready training state (scheduler, NumPy RNG, best metrics, ...).
        torch_rng_state: the global torch RNG state, or None.
    """

    config: ExperimentConfig
    model_state: dict[str, torch.Tensor]
    epoch: int = 0
    iteration: int = 0
    optimizer_state: dict[str, Any] | None = None
    extra: dict[str, Any] | None = None
    torch_rng_state: torch.Tensor | None = None


def _flatten_optimizer(state: dict[str, Any]) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    tensors: dict[str, torch.Tensor] = {}
    scalars: dict[str, dict[str, Any]] = {}
    for index, values in state["state"].items():
        for key, value in values.items():
            if isinstance(value, torch.Tensor):
                tensors[f"optim.{index}.{key}"] = value.detach().cpu().clone().contiguous()
            else:
                scalars.setdefault(str(index), {})[key] = value
    return tensors, {"param_groups": state["param_groups"], "scalars": scalars}


def _unflatten_optimizer(tensors: dict[str, torch.Tensor], meta: dict[str, Any]) -> dict[str, Any]:
    state: dict[int, dict[str, Any]] = {}
    for name, value in tensors.items():
        _, index, key = name.split(".", 2)
        state.setdefault(int(index), {})[key] = value
    for index, values in meta.get("scalars", {}).items():
        state.setdefault(int(index), {}).update(values)
    return {"state": state, "param_groups": meta["param_groups"]}


def save_checkpoint(path: str | Path, checkpoint: Checkpoint) -> None:
    """Write ``checkpoint`` atomically: a crash mid-write leaves the previous file intact."""
    path = Path(path)
    tensors = {
        f"model.{k}": v.detach().cpu().contiguous() for k, v in checkpoint.model_state.items()
    }
    optimizer_meta = None
    if checkpoint.optimizer_state is not None:
        optim_tensors, optimizer_meta = _flatten_optimizer(checkpoint.optimizer_state)
        tensors.update(optim_tensors)
    if checkpoint.torch_rng_state is not None:
        tensors["rng.torch"] = checkpoint.torch_rng_state.clone()
    metadata = {
        "format": FORMAT_NAME,
        "format_version": str(FORMAT_VERSION),
        "config": json.dumps(config_to_dict(checkpoint.config)),
        "epoch": str(checkpoint.epoch),
        "iteration": str(checkpoint.iteration),
        "optimizer": json.dumps(optimizer_meta),
        "extra": json.dumps(checkpoint.extra),
    }
    try:
        save_atomically(
            path,
            lambda temporary: save_file(tensors, str(temporary), metadata=metadata),
            fsync=True,
            suffix=".tmp",
        )
    except OSError as exc:  # e.g. a full disk: the previous file has not been touched
        kept = "is kept as it was" if path.exists() else "was not written"
        raise GrouptronError(
            f"{path}: could not write the checkpoint ({exc.strerror or exc}); {path.name} {kept}"
        ) from None


def _refuse(path: Path, why: str) -> GrouptronError:
    return GrouptronError(f"{path}: not a grouptron checkpoint: {why}")


def load_checkpoint(path: str | Path) -> Checkpoint:
    """Read a checkpoint written by :func:`save_checkpoint`.

    Only safetensors files are accepted: they hold raw tensors and JSON, so loading cannot run
    code. A pickle (e.g. a ``torch.save`` file) is refused with an explanation.

    Raises:
        GrouptronError: for a missing, truncated, foreign or pickled file.
    """
    path = Path(path)
    if not path.is_file():
        raise GrouptronError(f"{path}: checkpoint not found")
    with path.open("rb") as handle:
        head = handle.read(9)
    # safetensors: an 8-byte little-endian header length, then the JSON header's "{".
    if head[8:9] != b"{":
        if head[:1] == b"\x80" or head[:2] == b"PK":
            raise _refuse(
                path,
                "it is a pickle/torch.save file; grouptron never unpickles files because "
                "loading a pickle can run arbitrary code. Use a .safetensors checkpoint "
                "written by grouptron",
            )
        raise _refuse(path, "not a safetensors file")
    try:
        with safe_open(str(path), framework="pt") as handle:
            metadata = handle.metadata() or {}
        tensors = load_file(str(path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise _refuse(path, f"unreadable or truncated safetensors file ({exc})") from None
    if metadata.get("format") != FORMAT_NAME:
        raise _refuse(path, "its metadata does not name the grouptron format")
    try:
        version = int(metadata.get("format_version", "0"))
        if version > FORMAT_VERSION:
            raise _refuse(path, f"format version {version} is newer than this grouptron reads")
        config = experiment_from_stored(json.loads(metadata["config"]))
        optimizer_meta = json.loads(metadata.get("optimizer", "null"))
        extra = json.loads(metadata.get("extra", "null"))
        epoch, iteration = int(metadata.get("epoch", 0)), int(metadata.get("iteration", 0))
    except (KeyError, ValueError, TypeError) as exc:
        raise _refuse(path, f"bad metadata ({exc})") from None
    model_state = {k[6:]: v for k, v in tensors.items() if k.startswith("model.")}
    optim_tensors = {k: v for k, v in tensors.items() if k.startswith("optim.")}
    return Checkpoint(
        config=config,
        model_state=model_state,
        epoch=epoch,
        iteration=iteration,
        optimizer_state=(
            _unflatten_optimizer(optim_tensors, optimizer_meta) if optimizer_meta else None
        ),
        extra=extra,
        torch_rng_state=tensors.get("rng.torch"),
    )


def stored_checkpoints(root: str | Path) -> list[tuple[Path, ExperimentConfig]]:
    """Every ``<root>/*/best.safetensors`` with its stored configuration, in folder-name
    order; callers pick runs by configuration, never by folder name."""
    root = Path(root)
    if not root.is_dir():
        why = "is a file, not a folder" if root.exists() else "does not exist"
        raise GrouptronError(
            f"checkpoint folder {root} {why}; pass --checkpoints DIR, a folder of "
            f"<name>/{BEST_WEIGHTS_FILE}"
        )
    paths = sorted(root.glob(f"*/{BEST_WEIGHTS_FILE}"))
    return [(path, load_checkpoint(path).config) for path in paths]


def load_trained_model(path: str | Path) -> tuple[Forecaster, ExperimentConfig]:
    """The model stored in a checkpoint (weights loaded strictly, eval mode) and its config."""
    checkpoint = load_checkpoint(path)
    try:
        model = build_model(checkpoint.config)
    except GrouptronError as exc:
        raise GrouptronError(f"{path}: {exc}") from None
    load_weights(model, checkpoint.model_state, str(path))
    return model.eval(), checkpoint.config
