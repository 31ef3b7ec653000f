"""Model selection on validation data only: a fixed subset scored after every epoch, the best
few epochs kept, and the final choice among them on the whole validation part.

Scoring the whole validation part after every epoch cost a quarter of a univ epoch on 2 cores;
the subset keeps that under 10% while the final choice still sees every validation sample.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import constant_velocity_scores, evaluate_model
from grouptron.groups.assign import SampleGroups
from grouptron.io import write_text_atomically
from grouptron.model.checkpoint import (
    BEST_WEIGHTS_FILE,
    Checkpoint,
    load_checkpoint,
    save_checkpoint,
)
from grouptron.model.factory import build_model, load_weights
from grouptron.model.forecaster import Forecaster

BEST = BEST_WEIGHTS_FILE

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
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    groups: SampleGroups | None = None,
) -> dict[str, float]:
    """Most-likely ADE/FDE on validation samples (no augmentation, no dropout), next to the
    constant-velocity baseline's on the same samples for scale; a model that makes no most
    likely forecast is scored (under the same keys) by the point forecast it makes."""
    mode = "ml" if "ml" in model.point_forecasts else model.point_forecasts[0]
    scores = evaluate_model(
        model,
        config,
        samples,
        (mode,),
        batch_size=config.train.eval_batch_size,
        groups=groups,
        device=next(model.parameters()).device,
    )
    baseline = constant_velocity_scores(samples, config.data.horizon_steps).summary()
    return {
        "val_ml_ade": float(scores[0].ade),
        "val_ml_fde": float(scores[0].fde),
        "val_cv_ade": baseline.ade,
        "val_cv_fde": baseline.fde,
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
        """The validation part ``samples`` (and its ``groups``) with its fixed subset of ``size``
        samples (all of them when ``size`` is 0 or at least the part's size)."""
        keep = np.zeros(len(samples), dtype=bool)
        keep[validation_subset(len(samples), size)] = True
        subset_groups = groups.subset(keep, samples) if groups is not None else None
        return cls(samples, groups, samples.subset(keep), subset_groups)

    @property
    def is_subset(self) -> bool:
        """Whether the subset leaves out any of the validation samples."""
        return len(self.subset) < len(self.samples)


Candidates = list[tuple[int, float]]
"""(epoch, validation-subset ML FDE) of the kept candidate epochs, best first."""


def keep_candidate(
    candidates: Candidates, out_dir: Path, score: float, weights: Checkpoint
) -> Candidates:
    """Keep this epoch's ``weights`` when its subset ``score`` is among the best few so far;
    returns the new candidate list (files of dropped epochs are removed)."""
    folder = out_dir / CANDIDATES
    mine = (weights.epoch, score)
    ranked = sorted([*candidates, mine], key=lambda c: c[1])
    kept, dropped = ranked[:KEPT_CANDIDATES], ranked[KEPT_CANDIDATES:]
    if mine in kept:
        folder.mkdir(exist_ok=True)
        save_checkpoint(folder / f"epoch-{weights.epoch:03d}.safetensors", weights)
    for epoch, _ in dropped:
        (folder / f"epoch-{epoch:03d}.safetensors").unlink(missing_ok=True)
    return kept


def adopt_legacy_best(
    candidates: Candidates,
    config: ExperimentConfig,
    out_dir: Path,
    validation: Validation,
    *,
    device: torch.device,
) -> Candidates:
    """A run resumed from before candidate keeping: its best weights become a candidate,
    scored on the subset like every later epoch."""
    best = out_dir / BEST
    if candidates or not best.exists():
        return candidates
    checkpoint = load_checkpoint(best)
    model = build_model(config).to(device)
    load_weights(model, checkpoint.model_state, str(best))
    score = validate(model.eval(), config, validation.subset, validation.subset_groups)
    folder = out_dir / CANDIDATES
    folder.mkdir(exist_ok=True)
    save_checkpoint(folder / f"epoch-{checkpoint.epoch:03d}.safetensors", checkpoint)
    return [(checkpoint.epoch, score["val_ml_fde"])]


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


def select_last_epoch(out_dir: Path, epoch: int) -> dict[str, Any]:
    """The selection record of a run without validation data: its final epoch (already in
    ``best.safetensors``), written to ``selection.json``."""
    record = {"selected_epoch": epoch, "validation_samples": 0, "candidates": []}
    write_text_atomically(out_dir / SELECTION, json.dumps(record, indent=2) + "\n")
    return record
