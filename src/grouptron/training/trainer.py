"""The training loop: seeded, resumable, one checkpoint per epoch, validation every epoch.

Reads top to bottom: ``setup`` (``run_state``) builds the model, optimiser and RNG or restores
them, ``train_epoch`` runs the optimiser steps, ``_finish_epoch`` validates (``selection``) and
writes, and ``train`` ties them together.

After every epoch: a validation record in ``metrics.jsonl``/``.csv``, ``last.safetensors`` (the
full state, for ``resume``), ``best.safetensors`` (the best weights so far), the model card; at
the end of the schedule the final choice of ``best.safetensors`` on all validation samples. An
epoch stopped part-way is neither validated nor saved. On a CUDA device a resumed run continues
correctly but not bit for bit (the CUDA RNG is not saved).

With a multi-process ``cluster`` (torchrun), every process trains its share of each global
batch of ``batch_size`` samples under DDP; only the main process validates and writes files,
the others wait for it at the end of every epoch.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn.parallel import DistributedDataParallel
from tqdm import tqdm

from grouptron.config import ExperimentConfig, save_config
from grouptron.data.prepare.augment import draw_rotation_angles
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.groups.assign import SampleGroups
from grouptron.model.batch import Batch, make_batch
from grouptron.model.checkpoint import (
    TEMPORARY_CHECKPOINTS,
    save_checkpoint,
)
from grouptron.model.factory import uses_groups
from grouptron.model.forecaster import Forecaster, LossLike, TrainingStep
from grouptron.training.distributed import SINGLE, Cluster, global_mean
from grouptron.training.metrics_log import MetricsWriter
from grouptron.training.model_card import describe_device, write_model_card
from grouptron.training.precision import precision_name
from grouptron.training.progress import EpochProgress
from grouptron.training.run_state import LAST, TrainState, checkpoint_of, setup
from grouptron.training.selection import (
    BEST,
    Validation,
    adopt_legacy_best,
    keep_candidate,
    select_final,
    select_last_epoch,
    validate,
)

log = logging.getLogger(__name__)

CONFIG = "config.json"


def train_epoch(  # noqa: PLR0913 - the pass's options, all keyword-only
    state: TrainState,
    config: ExperimentConfig,
    samples: SampleSet,
    *,
    progress: bool,
    max_iterations: int | None = None,
    groups: SampleGroups | None = None,
    cluster: Cluster = SINGLE,
    network: torch.nn.Module | None = None,
    weights: np.ndarray | None = None,
) -> tuple[dict[str, float], bool]:
    """One pass over the shuffled training samples (or, with ``weights``, (S,) probabilities,
    ``epoch_length`` draws by them); returns mean loss terms and speed, and whether the pass
    was finished (False when stopped at ``max_iterations``).

    With several processes (``cluster``), each runs its share of every global batch through
    ``network`` (the model wrapped in DDP); the order, angles and noise are the same everywhere.
    """
    network = TrainingPass(state.model) if network is None else network
    state.model.train()
    order = epoch_order(state.rng, len(samples), weights, config.train.epoch_samples)
    size = config.train.batch_size
    starts = range(0, len(order), size)
    totals: dict[str, float] = {}
    seen, started = 0, time.perf_counter()
    shown = EpochProgress(state.epoch + 1, config.train.epochs, len(starts), shown=progress)
    finished = True
    skipped_before = state.nonfinite_steps
    for start in starts:  # the progress is closed below, also when stopped early
        if max_iterations is not None and state.iteration >= max_iterations:
            finished = False
            break
        index = order[start : start + size]
        terms = train_step(
            state, config, samples, index, groups=groups, cluster=cluster, network=network
        )
        if terms is None:
            continue
        state.iteration += 1
        seen += len(index)
        for key, value in terms.as_floats().items():
            totals[key] = totals.get(key, 0.0) + value * len(index)
        shown.step(len(index), float(terms.loss.detach()))
    shown.close()
    elapsed = time.perf_counter() - started
    means = {f"train_{k}": v / max(seen, 1) for k, v in totals.items()}
    means["train_seconds"] = elapsed
    means["train_samples_per_s"] = seen / elapsed if elapsed > 0 else 0.0
    means["nonfinite_steps"] = state.nonfinite_steps - skipped_before
    return means, finished


def epoch_order(
    rng: np.random.Generator, num_samples: int, weights: np.ndarray | None, epoch_samples: int
) -> np.ndarray:
    """(L,) the samples of one epoch in order: a shuffled pass over all ``num_samples``, or
    ``epoch_samples`` (default ``num_samples``) draws with replacement by ``weights``."""
    if weights is None and epoch_samples in (0, num_samples):
        return rng.permutation(num_samples)
    length = epoch_samples or num_samples
    if weights is None:
        return rng.choice(num_samples, size=length, replace=True)
    return rng.choice(num_samples, size=length, replace=True, p=weights / weights.sum())


def train_step(
    state: TrainState,
    config: ExperimentConfig,
    samples: SampleSet,
    index: np.ndarray,
    *,
    groups: SampleGroups | None,
    cluster: Cluster,
    network: torch.nn.Module,
) -> LossLike | None:
    """One optimiser step on the global batch ``index`` (this process's rows of it); None when
    the step was skipped for a non-finite loss or gradient."""
    device = next(state.model.parameters()).device
    angles = (
        draw_rotation_angles(state.rng, len(index)) if config.train.rotation_augmentation else None
    )
    noise = state.model.training_noise(len(index), config)  # the global batch's draws
    mine = cluster.shard(len(index))  # this process's rows of the global batch
    rotation = None if angles is None else angles[mine]
    batch = make_batch(samples, index[mine], config.data, rotation, groups=groups).to(device)
    step = TrainingStep(
        config=config,
        iteration=state.iteration,
        noise=None if noise is None else noise.rows(mine).to(device),
        batch_mean=functools.partial(global_mean, cluster=cluster, global_count=len(index)),
    )
    terms = network(batch, step)
    state.optimizer.zero_grad(set_to_none=True)
    # DDP averages the processes' gradients; each holds its rows' share of the whole loss.
    # Backward runs even for a non-finite loss so that DDP's gradient exchange completes
    # on every process; the loss is the whole global batch's everywhere and the gradients
    # are checked after averaging, so all processes agree on skipping the step.
    (terms.loss * cluster.world_size).backward()
    broken = _nonfinite_part(terms.loss, state.model)
    if broken is not None:
        state.optimizer.zero_grad(set_to_none=True)
        _skip_nonfinite_step(state, config, broken)
        return None
    torch.nn.utils.clip_grad_value_(state.model.parameters(), config.train.grad_clip_value)
    state.optimizer.step()
    state.scheduler.step()
    return terms


def _nonfinite_part(loss: torch.Tensor, model: torch.nn.Module) -> str | None:
    """``"loss"`` or ``"gradients"`` when that is NaN/inf after backward, else None."""
    if not torch.isfinite(loss.detach()):
        return "loss"
    grads = [p.grad for p in model.parameters() if p.grad is not None]
    return None if torch.isfinite(torch.nn.utils.get_total_norm(grads)) else "gradients"


def _skip_nonfinite_step(state: TrainState, config: ExperimentConfig, what: str) -> None:
    """Count a skipped step (weights untouched); stop the run past the configured limit."""
    state.nonfinite_steps += 1
    log.warning(
        "step %d skipped: non-finite %s (%d so far)", state.iteration, what, state.nonfinite_steps
    )
    limit = config.train.max_nonfinite_steps
    if state.nonfinite_steps > limit:
        raise GrouptronError(
            f"training stopped: {state.nonfinite_steps} steps with non-finite loss or "
            f"gradients (the last in epoch {state.epoch + 1}, {what}), more than "
            f"train.max_nonfinite_steps = {limit}; the last checkpoint of a finished epoch is "
            "intact (try a lower learning rate or look for bad training data)"
        )


def _finish_epoch(
    state: TrainState,
    config: ExperimentConfig,
    out_dir: Path,
    record: dict[str, Any],
    *,
    validation: Validation,
    device: torch.device,
    writer: MetricsWriter,
) -> None:
    """Validate, log, keep candidates, select at the end of the schedule, checkpoint, card."""
    record["precision"] = precision_name(config.train.bf16)
    if state.init_kind:
        record["initialised_from"] = state.init_kind
    if len(validation.samples):
        record.update(validate(state.model, config, validation.subset, validation.subset_groups))
        record["val_samples"] = len(validation.subset)
    record["epoch_seconds"] = time.perf_counter() - record.pop("_started")
    record["device"] = describe_device(device, config.train.threads)
    state.history.append(record)
    writer.write(record)
    val_fde = record.get("val_ml_fde", math.nan)
    if not math.isnan(val_fde):
        weights = checkpoint_of(state, config, weights_only=True)
        state.candidates = keep_candidate(state.candidates, out_dir, val_fde, weights)
        if val_fde < state.best_val_fde:
            state.best_val_fde = val_fde
            save_checkpoint(out_dir / BEST, weights)
    if not len(validation.samples):  # nothing to select on: the newest weights are kept
        save_checkpoint(out_dir / BEST, checkpoint_of(state, config, weights_only=True))
    selection = None
    if state.epoch == config.train.epochs and state.candidates:
        selection = select_final(config, out_dir, validation, device)
    elif state.epoch == config.train.epochs and not len(validation.samples):
        selection = select_last_epoch(out_dir, state.epoch)
    save_checkpoint(out_dir / LAST, checkpoint_of(state, config, weights_only=False))
    write_model_card(out_dir, config, writer.records(), selection)


def _open_run_folder(
    state: TrainState,
    config: ExperimentConfig,
    out_dir: Path,
    resume: bool,
    *,
    validation: Validation,
    device: torch.device,
) -> None:
    """Clear a killed process's temporaries, store the config, and on resume drop the metrics
    of unsaved epochs and adopt an older run's best weights as a candidate."""
    for stale in out_dir.glob(TEMPORARY_CHECKPOINTS):
        stale.unlink()
    save_config(config, out_dir / CONFIG)  # the same JSON as in the checkpoints
    if resume:
        MetricsWriter(out_dir).truncate_after(state.epoch)
        if len(validation.samples):
            state.candidates = adopt_legacy_best(
                state.candidates, config, out_dir, validation, device=device
            )


class TrainingPass(torch.nn.Module):
    """A model's training loss as a module's forward, which DDP wraps: its gradient exchange
    is set up by the forward it calls."""

    def __init__(self, model: Forecaster) -> None:
        super().__init__()
        self.model = model

    def forward(self, batch: Batch, step: TrainingStep) -> LossLike:
        """``model.training_loss(batch, step)``."""
        return self.model.training_loss(batch, step)


def _wrapped(model: Forecaster, cluster: Cluster, device: torch.device) -> torch.nn.Module:
    """The model as the optimiser steps see it: its training pass, wrapped in DDP with
    several processes."""
    if not cluster.distributed:
        return TrainingPass(model)
    device_ids = [device.index] if device.type == "cuda" else None
    return DistributedDataParallel(TrainingPass(model), device_ids=device_ids)


def epoch_line(record: dict[str, Any], epochs: int) -> str:
    """One readable line per epoch: ``epoch 3/100: loss 12.84; validation ML FDE 1.031 m
    (constant velocity 1.030 m) on a 1024-sample subset; 22.7 s``."""
    line = f"epoch {record['epoch']}/{epochs}: loss {record['train_loss']:.4g}"
    if "val_ml_fde" in record:
        line += (
            f"; validation ML FDE {record['val_ml_fde']:.3f} m (constant velocity "
            f"{record['val_cv_fde']:.3f} m) on a {record['val_samples']}-sample subset"
        )
    if record.get("nonfinite_steps"):
        line += f"; {record['nonfinite_steps']} non-finite steps skipped"
    return line + f"; {record.get('epoch_seconds', record.get('train_seconds', 0.0)):.1f} s"


def _check_inputs(
    config: ExperimentConfig,
    train_samples: SampleSet,
    train_groups: SampleGroups | None,
    val_groups: SampleGroups | None,
    *,
    cluster: Cluster,
) -> None:
    if len(train_samples) == 0:
        raise GrouptronError("no training samples")
    if uses_groups(config) and (train_groups is None or val_groups is None):
        raise GrouptronError(f"{config.model_name} needs the samples' groups")
    last_batch = (config.train.epoch_samples or len(train_samples)) % config.train.batch_size
    if 0 < last_batch < cluster.world_size:
        raise GrouptronError(
            f"the last batch of each epoch holds {last_batch} samples, fewer than the "
            f"{cluster.world_size} processes; choose another --batch-size"
        )


def train(  # noqa: PLR0913 - the run's options, all keyword-only
    config: ExperimentConfig,
    train_samples: SampleSet,
    val_samples: SampleSet,
    out_dir: Path,
    *,
    resume: bool = False,
    progress: bool = True,
    max_iterations: int | None = None,
    train_groups: SampleGroups | None = None,
    val_groups: SampleGroups | None = None,
    device: torch.device | str = "cpu",
    cluster: Cluster = SINGLE,
    train_weights: np.ndarray | None = None,
) -> TrainState:
    """Train for ``config.train.epochs`` epochs (the module docstring says what each epoch
    writes); Grouptron needs ``train_groups`` and ``val_groups``; ``train_weights`` (S,) draw
    an epoch's samples (:func:`epoch_order`). ``max_iterations`` stops after that many
    optimiser steps as if the process were killed there (to test ``resume``)."""
    _check_inputs(config, train_samples, train_groups, val_groups, cluster=cluster)
    out_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(config.train.threads)
    dev = torch.device(device)
    state = setup(config, out_dir, resume, dev)
    writes = cluster.is_main
    epoch_of = functools.partial(
        train_epoch,
        progress=progress and writes,  # one progress bar, the main process's
        groups=train_groups,
        cluster=cluster,
        network=_wrapped(state.model, cluster, dev),
        weights=train_weights,
    )
    writer = MetricsWriter(out_dir)
    validation = Validation.of(val_samples, val_groups, config.train.val_subset)
    if writes:
        _open_run_folder(state, config, out_dir, resume, validation=validation, device=dev)
    while state.epoch < config.train.epochs:
        if max_iterations is not None and state.iteration >= max_iterations:
            break
        record: dict[str, Any] = {"epoch": state.epoch + 1, "_started": time.perf_counter()}
        means, finished = epoch_of(state, config, train_samples, max_iterations=max_iterations)
        record.update(means)
        if not finished:
            break  # stopped mid-epoch, as if killed: nothing of this epoch is saved
        state.epoch += 1
        record["iteration"] = state.iteration
        record["learning_rate"] = state.scheduler.get_last_lr()[0]
        if not writes:  # the main process validates and saves; wait for it
            cluster.barrier()
            continue
        if cluster.distributed:
            record["processes"] = cluster.world_size
        _finish_epoch(
            state, config, out_dir, record, validation=validation, device=dev, writer=writer
        )
        if progress:
            tqdm.write(epoch_line(record, config.train.epochs))  # main process only
        cluster.barrier()
    return state
