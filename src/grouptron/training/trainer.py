"""The training loop: seeded, resumable, one checkpoint per epoch, validation every epoch.

Reads top to bottom: ``setup`` builds the model, optimiser and RNG (or restores them from a
checkpoint), ``train_epoch`` runs the optimiser steps, ``validate`` scores the validation set
and ``train`` ties them together and writes checkpoints and metrics.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn.parallel import DistributedDataParallel
from tqdm import tqdm

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import ExperimentConfig, save_config
from grouptron.data.augment import draw_rotation_angles
from grouptron.data.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import evaluate_model
from grouptron.groups.assign import SampleGroups
from grouptron.io import write_text_atomically
from grouptron.model.batch import make_batch
from grouptron.model.checkpoint import (
    TEMPORARY_CHECKPOINTS,
    Checkpoint,
    load_checkpoint,
    save_checkpoint,
)
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import build_model, load_weights, uses_groups
from grouptron.model.noise import draw_training_noise
from grouptron.training import schedules
from grouptron.training.distributed import SINGLE, Cluster, global_mean
from grouptron.training.losses import elbo_loss
from grouptron.training.metrics_log import MetricsWriter
from grouptron.training.model_card import describe_device, write_model_card
from grouptron.training.precision import precision_name

log = logging.getLogger(__name__)

LAST = "last.safetensors"
CONFIG = "config.json"
BEST = "best.safetensors"


@dataclass
class TrainState:
    """Everything that changes during training and must survive a restart."""

    model: TrajectronCVAE
    optimizer: torch.optim.Adam
    scheduler: torch.optim.lr_scheduler.ExponentialLR
    rng: np.random.Generator
    epoch: int = 0
    iteration: int = 0
    best_val_fde: float = math.inf
    nonfinite_steps: int = 0
    """Steps skipped because the loss or a gradient was NaN/inf (over the whole run)."""
    history: list[dict[str, Any]] = field(default_factory=list)
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
    extra = _restore(state, checkpoint, last, device, "cannot be resumed")
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
    """Start from another run's weights, optimiser state and step count (not its epochs).

    Used to move a trained model to other derivatives (e.g. central -> backward):
    the step count keeps the KL and logit-clip schedules and the learning-rate decay where
    the source run left them instead of re-annealing a trained model.
    """
    checkpoint = load_checkpoint(source)
    if checkpoint.config.model_name != config.model_name or (
        checkpoint.config.model != config.model
    ):
        raise GrouptronError(
            f"{source} holds a {checkpoint.config.model_name} model with other settings; "
            f"--init-from needs a {config.model_name} checkpoint of the same architecture"
        )
    _restore(state, checkpoint, source, device, "cannot start a run (--init-from)")


def _restore(
    state: TrainState, checkpoint: Checkpoint, source: Path, device: torch.device, use: str
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


def train_epoch(
    state: TrainState,
    config: ExperimentConfig,
    samples: SampleSet,
    progress: bool,
    max_iterations: int | None = None,
    groups: SampleGroups | None = None,
    cluster: Cluster = SINGLE,
    network: torch.nn.Module | None = None,
) -> tuple[dict[str, float], bool]:
    """One pass over the shuffled training samples; returns mean loss terms and speed, and
    whether the pass was finished (False when stopped at ``max_iterations``).

    With several processes (``cluster``), each runs its share of every global batch through
    ``network`` (the model wrapped in DDP); the order, angles and noise are the same everywhere.
    """
    network = state.model if network is None else network
    state.model.train()
    device = next(state.model.parameters()).device
    order = state.rng.permutation(len(samples))
    size = config.train.batch_size
    starts = range(0, len(order), size)
    totals: dict[str, float] = {}
    seen, started = 0, time.perf_counter()
    bar = tqdm(starts, desc=f"epoch {state.epoch + 1}", unit="it", disable=not progress)
    finished = True
    skipped_before = state.nonfinite_steps
    for start in bar:  # closed below, also when stopped early
        if max_iterations is not None and state.iteration >= max_iterations:
            finished = False
            break
        index = order[start : start + size]
        angles = (
            draw_rotation_angles(state.rng, len(index))
            if config.train.rotation_augmentation
            else None
        )
        noise = draw_training_noise(len(index), config.model, config.data.horizon_steps)
        mine = cluster.shard(len(index))  # this process's rows of the global batch
        batch = make_batch(
            samples, index[mine], config.data, None if angles is None else angles[mine], groups
        )
        batch = batch.to(device)
        output = network(
            batch,
            noise.rows(mine).to(device),
            logit_clip=schedules.logit_clip(config.loss, state.iteration),
            bf16=config.train.bf16,
        )
        terms = elbo_loss(
            output,
            batch,
            config.loss,
            schedules.kl_weight(config.loss, state.iteration),
            config.data.dt_s,
            batch_mean=functools.partial(global_mean, cluster=cluster, global_count=len(index)),
        )
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
            continue
        torch.nn.utils.clip_grad_value_(state.model.parameters(), config.train.grad_clip_value)
        state.optimizer.step()
        state.scheduler.step()
        state.iteration += 1
        seen += len(index)
        for key, value in terms.as_floats().items():
            totals[key] = totals.get(key, 0.0) + value * len(index)
        elapsed = time.perf_counter() - started
        bar.set_postfix(loss=f"{float(terms.loss.detach()):.3f}", samples_s=f"{seen / elapsed:.0f}")
    bar.close()
    elapsed = time.perf_counter() - started
    means = {f"train_{k}": v / max(seen, 1) for k, v in totals.items()}
    means["train_seconds"] = elapsed
    means["train_samples_per_s"] = seen / elapsed if elapsed > 0 else 0.0
    means["nonfinite_steps"] = state.nonfinite_steps - skipped_before
    return means, finished


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


VALIDATION_SUBSET_SEED = 0
"""The validation subset is drawn with this seed, not the run's, so that runs of every seed
are compared on the same samples."""
CANDIDATES = "candidates"
KEPT_CANDIDATES = 3
"""Epochs kept (weights only) by their subset score, re-scored on the whole validation part at
the end of the schedule."""
SELECTION = "selection.json"


def validation_subset(num_samples: int, size: int) -> np.ndarray:
    """(S,) sorted indices of the fixed, seeded validation subset (all when ``size`` is 0 or at
    least ``num_samples``)."""
    if size == 0 or size >= num_samples:
        return np.arange(num_samples)
    rng = np.random.default_rng(VALIDATION_SUBSET_SEED)
    return np.sort(rng.choice(num_samples, size=size, replace=False))


def validate(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    samples: SampleSet,
    groups: SampleGroups | None = None,
) -> dict[str, float]:
    """Most-likely ADE/FDE on validation samples (no augmentation, no dropout), next to the
    constant-velocity baseline's on the same samples for scale."""
    scores = evaluate_model(
        model,
        config,
        samples,
        ("ml",),
        batch_size=config.train.eval_batch_size,
        groups=groups,
        device=next(model.parameters()).device,
    )
    truth = samples.fut_rel_m.astype(np.float64)
    baseline = constant_velocity(samples.hist_rel_m.astype(np.float64), config.data.horizon_steps)
    return {
        "val_ml_ade": float(scores[0].ade),
        "val_ml_fde": float(scores[0].fde),
        "val_cv_ade": float(metrics.ade(baseline, truth).mean()),
        "val_cv_fde": float(metrics.fde(baseline, truth).mean()),
    }


@dataclass(frozen=True)
class Validation:
    """The validation part and the subset of it scored after every epoch."""

    samples: SampleSet
    groups: SampleGroups | None
    subset: SampleSet
    subset_groups: SampleGroups | None

    @classmethod
    def of(cls, samples: SampleSet, groups: SampleGroups | None, size: int) -> Validation:
        keep = np.zeros(len(samples), dtype=bool)
        keep[validation_subset(len(samples), size)] = True
        subset_groups = groups.subset(keep, samples) if groups is not None else None
        return cls(samples, groups, samples.subset(keep), subset_groups)

    @property
    def is_subset(self) -> bool:
        return len(self.subset) < len(self.samples)


def _keep_candidate(
    state: TrainState, config: ExperimentConfig, out_dir: Path, score: float
) -> None:
    """Keep this epoch's weights when its subset score is among the best few so far."""
    folder = out_dir / CANDIDATES
    ranked = sorted([*state.candidates, (state.epoch, score)], key=lambda c: c[1])
    kept, dropped = ranked[:KEPT_CANDIDATES], ranked[KEPT_CANDIDATES:]
    if (state.epoch, score) in kept:
        folder.mkdir(exist_ok=True)
        save_checkpoint(
            folder / f"epoch-{state.epoch:03d}.safetensors",
            _checkpoint(state, config, weights_only=True),
        )
    for epoch, _ in dropped:
        (folder / f"epoch-{epoch:03d}.safetensors").unlink(missing_ok=True)
    state.candidates = kept


def _adopt_legacy_best(
    state: TrainState, config: ExperimentConfig, out_dir: Path, validation: Validation
) -> None:
    """A run resumed from before candidate keeping: its best weights become a candidate,
    scored on the subset like every later epoch."""
    best = out_dir / BEST
    if state.candidates or not best.exists():
        return
    checkpoint = load_checkpoint(best)
    model = build_model(config).to(next(state.model.parameters()).device)
    load_weights(model, checkpoint.model_state, str(best))
    score = validate(model.eval(), config, validation.subset, validation.subset_groups)
    folder = out_dir / CANDIDATES
    folder.mkdir(exist_ok=True)
    save_checkpoint(folder / f"epoch-{checkpoint.epoch:03d}.safetensors", checkpoint)
    state.candidates = [(checkpoint.epoch, score["val_ml_fde"])]


def select_final(
    config: ExperimentConfig, out_dir: Path, validation: Validation, device: torch.device
) -> dict[str, Any]:
    """Score every kept candidate on the whole validation part; the best becomes
    ``best.safetensors``. Returns the selection record (also written to ``selection.json``)."""
    scored = []
    for path in sorted((out_dir / CANDIDATES).glob("epoch-*.safetensors")):
        checkpoint = load_checkpoint(path)
        model = build_model(config).to(device)
        load_weights(model, checkpoint.model_state, str(path))
        scores = validate(model.eval(), config, validation.samples, validation.groups)
        scored.append((scores["val_ml_fde"], checkpoint.epoch, path, scores))
    if not scored:
        raise GrouptronError(f"{out_dir}: no candidate epochs to select from")
    _, epoch, path, scores = min(scored, key=lambda c: (c[0], c[1]))
    save_checkpoint(out_dir / BEST, load_checkpoint(path))
    record = {
        "selected_epoch": epoch,
        "validation_samples": len(validation.samples),
        **{f"full_{k}": v for k, v in scores.items()},
        "candidates": [{"epoch": e, "full_val_ml_fde": f} for f, e, _, _ in sorted(scored)],
    }
    write_text_atomically(out_dir / SELECTION, json.dumps(record, indent=2) + "\n")
    return record


def _checkpoint(state: TrainState, config: ExperimentConfig, weights_only: bool) -> Checkpoint:
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


def train(
    config: ExperimentConfig,
    train_samples: SampleSet,
    val_samples: SampleSet,
    out_dir: Path,
    resume: bool = False,
    progress: bool = True,
    max_iterations: int | None = None,
    train_groups: SampleGroups | None = None,
    val_groups: SampleGroups | None = None,
    device: torch.device | str = "cpu",
    cluster: Cluster = SINGLE,
) -> TrainState:
    """Train for ``config.train.epochs`` epochs.

    ``max_iterations`` stops after that many optimiser steps as if the process were killed
    there: an unfinished epoch is neither validated nor saved (used to test ``resume``).

    After every epoch: validation, ``last.safetensors`` (full state, for ``resume``),
    ``best.safetensors`` (weights, when the validation ML FDE improved) and a metrics record.
    Grouptron needs ``train_groups`` and ``val_groups`` (the samples' groups). On a CUDA
    ``device`` a resumed run continues correctly but not bit for bit (the CUDA RNG is not saved).

    With a multi-process ``cluster`` (torchrun), every process trains its share of each global
    batch of ``batch_size`` samples under DDP; only the main process validates and writes files,
    the others wait for it at the end of every epoch.
    """
    if len(train_samples) == 0:
        raise GrouptronError("no training samples")
    if uses_groups(config) and (train_groups is None or val_groups is None):
        raise GrouptronError(f"{config.model_name} needs the samples' groups")
    last_batch = len(train_samples) % config.train.batch_size
    if 0 < last_batch < cluster.world_size:
        raise GrouptronError(
            f"the last batch of each epoch holds {last_batch} samples, fewer than the "
            f"{cluster.world_size} processes; choose another --batch-size"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(config.train.threads)
    state = setup(config, out_dir, resume, torch.device(device))
    network: torch.nn.Module = state.model
    if cluster.distributed:
        device_ids = [torch.device(device).index] if torch.device(device).type == "cuda" else None
        network = DistributedDataParallel(state.model, device_ids=device_ids)
    writes = cluster.is_main
    progress = progress and writes  # one progress bar, the main process's
    if writes:
        for stale in out_dir.glob(TEMPORARY_CHECKPOINTS):  # left behind by a killed process
            stale.unlink()
        save_config(config, out_dir / CONFIG)  # the same JSON as in the checkpoints
    writer = MetricsWriter(out_dir)
    validation = Validation.of(val_samples, val_groups, config.train.val_subset)
    if resume and writes:
        writer.truncate_after(state.epoch)
        if len(val_samples):
            _adopt_legacy_best(state, config, out_dir, validation)
    while state.epoch < config.train.epochs:
        if max_iterations is not None and state.iteration >= max_iterations:
            break
        record: dict[str, Any] = {"epoch": state.epoch + 1}
        epoch_started = time.perf_counter()
        means, finished = train_epoch(
            state,
            config,
            train_samples,
            progress,
            max_iterations,
            train_groups,
            cluster,
            network,
        )
        record.update(means)
        if not finished:
            break  # stopped mid-epoch, as if killed: nothing of this epoch is saved
        state.epoch += 1
        record["iteration"] = state.iteration
        record["learning_rate"] = state.scheduler.get_last_lr()[0]
        if not writes:  # the main process validates and saves; wait for it
            cluster.barrier()
            continue
        record["precision"] = precision_name(config.train.bf16)
        if len(val_samples):
            record.update(
                validate(state.model, config, validation.subset, validation.subset_groups)
            )
            record["val_samples"] = len(validation.subset)
        record["epoch_seconds"] = time.perf_counter() - epoch_started
        record["device"] = describe_device(torch.device(device), config.train.threads)
        if cluster.distributed:
            record["processes"] = cluster.world_size
        state.history.append(record)
        writer.write(record)
        val_fde = record.get("val_ml_fde", math.nan)
        if not math.isnan(val_fde):
            _keep_candidate(state, config, out_dir, val_fde)
            if val_fde < state.best_val_fde:
                state.best_val_fde = val_fde
                save_checkpoint(out_dir / BEST, _checkpoint(state, config, weights_only=True))
        selection = None
        if state.epoch == config.train.epochs and state.candidates:
            selection = select_final(config, out_dir, validation, torch.device(device))
        save_checkpoint(out_dir / LAST, _checkpoint(state, config, weights_only=False))
        write_model_card(out_dir, config, writer.records(), selection)
        if progress:
            shown = {k: round(v, 4) for k, v in record.items() if isinstance(v, float)}
            tqdm.write(f"epoch {state.epoch}: {shown}")
        cluster.barrier()
    return state
