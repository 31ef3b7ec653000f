"""A training run's state: what changes during training and must survive a restart, how it
starts (from the seed, a resumed run or another run's weights) and how it is saved."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import Checkpoint, load_checkpoint
from grouptron.model.factory import build_model, load_weights, uses_groups
from grouptron.model.forecaster import Forecaster

LAST = "last.safetensors"


@dataclass
class TrainState:
    """Everything that changes during training and must survive a restart."""

    model: Forecaster
    optimizer: torch.optim.Adam
    scheduler: torch.optim.lr_scheduler.ExponentialLR
    rng: np.random.Generator
    epoch: int = 0
    iteration: int = 0
    best_val_fde: float = math.inf
    nonfinite_steps: int = 0
    """Steps skipped because the loss or a gradient was NaN/inf (over the whole run)."""
    history: list[dict[str, Any]] = field(default_factory=list)
    init_kind: str = ""
    """What ``train.init_from`` gave this run: weights only or a whole training state."""
    candidates: list[tuple[int, float]] = field(default_factory=list)
    """(epoch, validation-subset ML FDE) of the kept candidate epochs."""


def _without_length(config: ExperimentConfig) -> ExperimentConfig:
    """The config without the settings a resumed run may change (epochs, threads, precision;
    every epoch's precision is in its metrics record)."""
    return dataclasses.replace(
        config, train=dataclasses.replace(config.train, epochs=1, threads=1, bf16=False)
    )


def setup(
    config: ExperimentConfig, out_dir: Path, resume: bool, device: torch.device
) -> TrainState:
    """Fresh state from the seed, or the state of ``out_dir/last.safetensors`` on resume."""
    torch.manual_seed(config.train.seed)
    model = build_model(config).to(device)
    if not any(True for _ in model.parameters()):
        raise GrouptronError(f"{config.model_name} has no parameters to train")
    optimizer = torch.optim.Adam(model.parameters(), lr=config.train.learning_rate)
    scheduler = torch.optim.lr_scheduler.ExponentialLR(optimizer, config.train.lr_decay_per_iter)
    state = TrainState(model, optimizer, scheduler, np.random.default_rng(config.train.seed))
    last = out_dir / LAST
    if not resume:
        if last.exists():
            raise GrouptronError(
                f"{out_dir} already holds a training run; pass --resume to continue it or "
                "choose another --out"
            )
        if config.train.init_from:
            _warm_start(state, config, Path(config.train.init_from), device)
        return state
    if not last.exists():
        raise GrouptronError(f"nothing to resume: {last} does not exist")
    checkpoint = load_checkpoint(last)
    if _without_length(checkpoint.config) != _without_length(config):
        raise GrouptronError(
            f"{last} was trained with a different configuration; resume with the same options"
        )
    extra = _restore(state, checkpoint, last, device, use="cannot be resumed")
    try:
        state.rng.bit_generator.state = extra["numpy_rng"]
        if checkpoint.torch_rng_state is not None:
            torch.set_rng_state(checkpoint.torch_rng_state)
    except (KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise GrouptronError(f"{last} cannot be resumed: damaged training state ({exc})") from None
    state.epoch = checkpoint.epoch
    state.best_val_fde = extra.get("best_val_fde", math.inf)
    state.nonfinite_steps = int(extra.get("nonfinite_steps", 0))
    state.candidates = [(int(e), float(f)) for e, f in extra.get("candidates", [])]
    if "candidates" not in extra:
        state.best_val_fde = math.inf  # scored on the whole part; later epochs on the subset
    return state


def _warm_start(
    state: TrainState, config: ExperimentConfig, source: Path, device: torch.device
) -> None:
    """Start from another run's checkpoint (not its epochs).

    A weights-only file (``best.safetensors``, a shipped model) fine-tunes: its weights, a fresh
    optimiser at this run's learning rate, schedules from step 0. A full training state
    (``last.safetensors``) continues: its optimiser moments and step count keep the KL and
    logit-clip schedules and the learning-rate decay where the source run left them (used to
    move a trained model to other derivatives); a learning rate other than the source run's is
    applied from the first step on.
    """
    checkpoint = load_checkpoint(source)
    source_config = checkpoint.config
    same_architecture = (source_config.model_name, source_config.model) == (
        config.model_name,
        config.model,
    ) and (not uses_groups(config) or source_config.group_encoder == config.group_encoder)
    if not same_architecture:
        raise GrouptronError(
            f"{source} holds a {source_config.model_name} model with other settings; "
            f"--init-from needs a {config.model_name} checkpoint of the same architecture"
        )
    if checkpoint.optimizer_state is None:
        weights = {k: v.to(device) for k, v in checkpoint.model_state.items()}
        load_weights(state.model, weights, str(source))
        state.init_kind = "weights (fresh optimiser, schedules from step 0)"
        return
    _restore(state, checkpoint, source, device, use="cannot start a run (--init-from)")
    state.init_kind = "training state (its optimiser and step count continue)"
    if config.train.learning_rate != source_config.train.learning_rate:
        for group in state.optimizer.param_groups:
            group["lr"] = config.train.learning_rate
        state.scheduler.base_lrs = [config.train.learning_rate] * len(state.scheduler.base_lrs)
        state.scheduler._last_lr = [config.train.learning_rate] * len(state.scheduler.base_lrs)


def _restore(
    state: TrainState, checkpoint: Checkpoint, source: Path, device: torch.device, *, use: str
) -> dict[str, Any]:
    """Weights, optimiser, scheduler and step count of a full training checkpoint; returns the
    checkpoint's extra state (RNG, best score) for a resume."""
    if checkpoint.optimizer_state is None or checkpoint.extra is None:
        raise GrouptronError(f"{source} holds weights only and {use}; it needs last.safetensors")
    weights = {k: v.to(device) for k, v in checkpoint.model_state.items()}
    load_weights(state.model, weights, str(source))
    try:
        state.optimizer.load_state_dict(checkpoint.optimizer_state)
        state.scheduler.load_state_dict(checkpoint.extra["scheduler"])
    except (KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise GrouptronError(f"{source} {use}: damaged training state ({exc})") from None
    state.iteration = checkpoint.iteration
    return checkpoint.extra


def checkpoint_of(state: TrainState, config: ExperimentConfig, weights_only: bool) -> Checkpoint:
    """A checkpoint of the training state; ``weights_only`` leaves out the optimiser
    state and torch's RNG state (what ``last.safetensors`` needs to resume)."""
    return Checkpoint(
        config=config,
        model_state=state.model.state_dict(),
        epoch=state.epoch,
        iteration=state.iteration,
        optimizer_state=None if weights_only else state.optimizer.state_dict(),
        extra={
            "scheduler": state.scheduler.state_dict(),
            "numpy_rng": state.rng.bit_generator.state,
            "best_val_fde": state.best_val_fde,
            "nonfinite_steps": state.nonfinite_steps,
            "last_metrics": state.history[-1] if state.history else None,
            "candidates": [list(c) for c in state.candidates],
        },
        torch_rng_state=None if weights_only else torch.get_rng_state(),
    )
