"""Evaluate a folder of checkpoints on every test set: the rows behind the paper's tables.

The folder holds ``<model>-<split>-<protocol>/best.safetensors`` (e.g.
``grouptron-eth-central``). Each checkpoint is scored on its split's test set once per mode;
UNIV-N rows are means over the univ samples with N or more people in view (every sample is
predicted independently, so this equals evaluating the subset). Constant velocity is scored
alongside. ``report_markdown`` (in :mod:`grouptron.evaluation.report_tables`) turns the rows
into the paper's tables.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import DataConfig
from grouptron.data.constants import SPLITS, UNIV_N_PAPER
from grouptron.data.samples import SampleSet
from grouptron.data.subsets import univ_n_mask
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import MODES, SampleScores, score_samples
from grouptron.evaluation.results import EvaluationResult, mean_over_splits, score
from grouptron.evaluation.test_sets import load_test_set, subset_with_groups
from grouptron.geometry import DERIVATIVE_SCHEMES, DerivativeScheme
from grouptron.model.factory import MODEL_NAMES, uses_groups
from grouptron.training.checkpoint import load_trained_model

log = logging.getLogger(__name__)

PROTOCOLS = DERIVATIVE_SCHEMES
"""``central`` (the papers' protocol) and ``backward`` (causal)."""
CONSTANT_VELOCITY = "constant-velocity"
WEIGHTS_FILE = "best.safetensors"


@dataclass(frozen=True)
class ReportCheckpoint:
    """One shipped checkpoint and what its folder name says it is."""

    model: str
    split: str
    protocol: DerivativeScheme
    path: Path


@dataclass(frozen=True)
class ReportSettings:
    modes: tuple[str, ...] = ("ml", "best-of-20", "nll")
    seed: int = 0
    nll_max_samples: int = 0
    """KDE NLL on at most this many seeded random test samples per split (0: all of them);
    2000 decoded futures per sample make the full NLL the slow part on a CPU."""
    batch_size: int = 256
    use_cache: bool = True

    def __post_init__(self) -> None:
        unknown = [m for m in self.modes if m not in MODES]
        if unknown or not self.modes:
            raise GrouptronError(f"unknown report modes {unknown}; choose from {MODES}")
        if self.nll_max_samples < 0:
            raise GrouptronError("the NLL sample cap must be >= 0 (0 means all samples)")


def find_checkpoints(root: Path, protocols: Sequence[DerivativeScheme]) -> list[ReportCheckpoint]:
    """The ``<model>-<split>-<protocol>/best.safetensors`` under ``root``, in table order.

    Missing ones are logged (their cells stay empty); finding none at all is an error.
    """
    if not root.is_dir():
        raise GrouptronError(f"checkpoint folder {root} does not exist; pass --checkpoints DIR")
    found, missing = [], []
    for protocol in protocols:
        for model in MODEL_NAMES:
            for split in SPLITS:
                path = root / f"{model}-{split}-{protocol}" / WEIGHTS_FILE
                if path.is_file():
                    found.append(ReportCheckpoint(model, split, protocol, path))
                else:
                    missing.append(path.parent.name)
    if not found:
        raise GrouptronError(
            f"no checkpoints in {root}: expected folders like {MODEL_NAMES[0]}-eth-"
            f"{protocols[0]}/{WEIGHTS_FILE}"
        )
    if missing:
        log.warning(
            "%d checkpoints missing in %s (their cells stay empty): %s",
            len(missing),
            root,
            ", ".join(missing),
        )
    return found


def subset_masks(split: str, samples: SampleSet) -> dict[str | None, np.ndarray | None]:
    """The whole test set (None) and, for univ, the paper's UNIV-N masks."""
    masks: dict[str | None, np.ndarray | None] = {None: None}
    if split == "univ":
        masks.update({f"univ-{n}": univ_n_mask(samples, n) for n in UNIV_N_PAPER})
    return masks


def nll_subsample(count: int, cap: int, seed: int) -> np.ndarray:
    """(S,) mask of the samples whose NLL is computed: all, or ``cap`` drawn with ``seed``."""
    keep = np.ones(count, dtype=bool)
    if 0 < cap < count:
        keep[:] = False
        keep[np.random.default_rng(seed).choice(count, cap, replace=False)] = True
    return keep


def _rows(
    scores: SampleScores,
    masks: dict[str | None, np.ndarray | None],
    within: np.ndarray | None,
    template: EvaluationResult,
) -> list[EvaluationResult]:
    """One row per subset. ``within`` is the (S,) mask of the samples ``scores`` cover when
    they cover only some (the NLL subsample); subset masks are narrowed to it."""
    rows = []
    for subset, keep in masks.items():
        mask = keep if keep is None or within is None else keep[within]
        summary = scores.summary(mask)
        rows.append(
            EvaluationResult(
                split=template.split,
                model=template.model,
                subset=subset,
                samples=summary.samples,
                ade=summary.ade,
                fde=summary.fde,
                mode=scores.mode,
                nll=summary.nll if scores.mode == "nll" else None,
                checkpoint=template.checkpoint,
                protocol=template.protocol,
            )
        )
    return rows


def evaluate_checkpoint(
    entry: ReportCheckpoint,
    data_dir: Path,
    settings: ReportSettings,
    progress: bool = False,
) -> list[EvaluationResult]:
    """All rows of one checkpoint: each mode on its test set and, for univ, on UNIV-N."""
    model, experiment = load_trained_model(entry.path)
    stored = (experiment.model_name, experiment.split, experiment.data.derivatives)
    if stored != (entry.model, entry.split, entry.protocol):
        raise GrouptronError(
            f"{entry.path}: its folder says {entry.model} on {entry.split} ({entry.protocol}) "
            f"but it holds {stored[0]} on {stored[1]} ({stored[2]})"
        )
    group_config = experiment.groups if uses_groups(experiment) else None
    samples, groups = load_test_set(
        data_dir, entry.split, experiment.data, None, group_config, settings.use_cache
    )
    masks = subset_masks(entry.split, samples)
    template = EvaluationResult(
        entry.split, entry.model, None, 0, 0.0, 0.0, None, None, str(entry.path), entry.protocol
    )
    rows = []
    full_modes = tuple(m for m in settings.modes if m != "nll")
    batch, seed = settings.batch_size, settings.seed
    for scores in score_samples(
        model, experiment, samples, full_modes, batch, seed, progress, groups
    ):
        rows += _rows(scores, masks, None, template)
    if "nll" in settings.modes:
        keep = nll_subsample(len(samples), settings.nll_max_samples, seed)
        some, some_groups = subset_with_groups(samples, groups, keep)
        (scores,) = score_samples(
            model, experiment, some, ("nll",), batch, seed, progress, some_groups
        )
        rows += _rows(scores, masks, keep, template)
    return rows


def evaluate_constant_velocity(
    data_dir: Path, protocol: DerivativeScheme, use_cache: bool = True
) -> list[EvaluationResult]:
    """Constant-velocity rows of every split and UNIV-N (its inputs are raw positions, so
    both protocols give the same numbers)."""
    config = DataConfig(derivatives=protocol)
    rows = []
    for split in SPLITS:
        samples, _ = load_test_set(data_dir, split, config, use_cache=use_cache)
        for subset, keep in subset_masks(split, samples).items():
            part = samples if keep is None else samples.subset(keep)
            pred = constant_velocity(part.hist_rel_m.astype(np.float64), config.horizon_steps)
            row = score(split, CONSTANT_VELOCITY, subset, pred, part)
            rows.append(dataclasses.replace(row, mode="ml", protocol=protocol))
    return rows


def with_split_means(rows: list[EvaluationResult]) -> list[EvaluationResult]:
    """``rows`` plus the AVG row of every (model, protocol, mode) scored on all five splits."""
    means = []
    keys = dict.fromkeys((r.model, r.protocol, r.mode) for r in rows if r.subset is None)
    for model, protocol, mode in keys:
        per_split = [
            r
            for r in rows
            if (r.model, r.protocol, r.mode, r.subset) == (model, protocol, mode, None)
        ]
        if sorted(r.split for r in per_split) == sorted(SPLITS):
            means.append(mean_over_splits(per_split))
    return rows + means


def run_report(
    data_dir: Path,
    checkpoints: Sequence[ReportCheckpoint],
    protocols: Sequence[DerivativeScheme],
    settings: ReportSettings,
    progress: bool = False,
) -> list[EvaluationResult]:
    """Rows for every checkpoint and constant velocity, plus the AVG rows."""
    rows: list[EvaluationResult] = []
    baseline = evaluate_constant_velocity(data_dir, protocols[0], settings.use_cache)
    for protocol in protocols:  # the same numbers under both protocols: scored once
        rows += [dataclasses.replace(r, protocol=protocol) for r in baseline]
    for entry in checkpoints:
        log.info("evaluating %s", entry.path)
        if progress:
            print(f"{entry.model} {entry.split} ({entry.protocol}): {entry.path}", flush=True)
        with torch.inference_mode():
            rows += evaluate_checkpoint(entry, data_dir, settings, progress)
    return with_split_means(rows)
