"""Evaluate a folder of checkpoints on every test set: the rows behind the paper's tables.

The folder holds ``<model>-<split>-<derivatives>/best.safetensors`` (e.g.
``grouptron-eth-central``). Each checkpoint is scored on its split's test set once per mode;
UNIV-N rows are means over the univ samples with N or more people in view (every sample is
predicted independently, so this equals evaluating the subset). Constant velocity is scored
alongside. ``report_markdown`` (in :mod:`grouptron.reporting.tables`) turns the rows
into the paper's tables.
"""

from __future__ import annotations

import dataclasses
import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.constants import CONSTANT_VELOCITY, REPORT_NLL_MAX_SAMPLES, SPLITS, UNIV_N_PAPER
from grouptron.data.datasets.subsets import (
    UNIV_N_DEFINITIONS,
    UnivN,
    density_masks,
    time_step_ids,
    univ_n_mask,
)
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import (
    MODES,
    constant_velocity_scores,
)
from grouptron.evaluation.results import EvaluationResult, score_rows
from grouptron.evaluation.score_cache import cached_score_samples
from grouptron.evaluation.scored import ReportCheckpoint, ScoredRun
from grouptron.evaluation.test_sets import load_test_set, subset_with_groups
from grouptron.geometry import DerivativeScheme
from grouptron.model.checkpoint import BEST_WEIGHTS_FILE, load_trained_model, stored_checkpoints
from grouptron.model.factory import MODEL_NAMES, PAPER_MODELS, uses_groups
from grouptron.model.forecaster import Forecaster, is_outside_name
from grouptron.point_forecast import PointForecast, is_evaluation_mode, is_point_forecast
from grouptron.presets import run_label
from grouptron.reporting.stats import Report, build_report

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ReportSettings:
    """What a report scores and how: modes, seed, NLL sample cap, batch size and caches."""

    modes: tuple[str, ...] = ("ml", "best-of-20", "nll")
    seed: int = 0
    nll_max_samples: int = REPORT_NLL_MAX_SAMPLES
    """KDE NLL on at most this many seeded random test samples per split (0: all of them);
    2000 decoded futures per sample make the full NLL the slow part on a CPU (hours for all
    test samples of all checkpoints, minutes for 300 per split)."""
    batch_size: int = 256
    use_cache: bool = True
    score_cache: Path | None = None
    """Where per-sample scores are kept between reports (``evaluation.score_cache``; None: not
    kept), so that a report scores only checkpoints, modes and settings it has not seen."""
    diagnostics: bool = False
    """Also score by density and with each input taken away (``reporting.diagnostics``):
    one more ML pass per ablation a model has."""

    def __post_init__(self) -> None:
        unknown = [m for m in self.modes if not is_evaluation_mode(m)]
        if unknown or not self.modes:
            raise GrouptronError(
                f"unknown report modes {unknown}; choose from {', '.join(MODES)}, ml-topK or "
                "best-of-K"
            )
        if self.diagnostics and "ml" not in self.modes:
            raise GrouptronError("the density and ablation tables need the ml mode")
        if self.nll_max_samples < 0:
            raise GrouptronError("the NLL sample cap must be >= 0 (0 means all samples)")


def find_checkpoints(
    root: Path,
    schemes: Sequence[DerivativeScheme],
    models: Sequence[str] = MODEL_NAMES,
    seeds: Sequence[int] | None = None,
    splits: Sequence[str] = SPLITS,
) -> list[ReportCheckpoint]:
    """Every ``*/best.safetensors`` under ``root`` whose stored configuration is one of
    ``models`` on one of the ETH/UCY ``splits`` under one of ``schemes`` (and trained with one
    of ``seeds``; None: any), in table order (derivatives, model, split, seed). Folder names
    do not matter; several seeds of one model and split are kept.

    Missing (model, split, derivatives) cells are logged (they stay empty); none at all is an
    error.
    """
    found = []
    for path, config in stored_checkpoints(root):
        derivatives = config.data.derivatives
        label = run_label(config)  # a run with other switches is not its code's model
        if (
            derivatives in schemes
            and config.split in splits
            and _reported(config, label, models)
            and (seeds is None or config.train.seed in seeds)
        ):
            found.append(
                ReportCheckpoint(label, config.split, derivatives, path, config.train.seed)
            )
    if not found:
        seeded = "" if seeds is None else f" trained with seed {' or '.join(map(str, seeds))}"
        raise GrouptronError(
            f"no checkpoints in {root} for the {'/'.join(schemes)} derivatives: expected "
            f"folders with a {BEST_WEIGHTS_FILE} of {' or '.join(models)} on "
            f"{' or '.join(splits) if tuple(splits) != SPLITS else 'an ETH/UCY split'}{seeded}"
        )
    order = {name: i for i, name in enumerate((*schemes, *MODEL_NAMES, *SPLITS))}
    found.sort(
        key=lambda c: (
            order[c.derivatives],
            order.get(c.model, len(order)),  # other runs after the named models, by name
            c.model,
            order[c.split],
            c.seed,
        )
    )
    have = {(c.model, c.split, c.derivatives) for c in found}
    # The paper's two models are expected on every split; a variant only where it was trained.
    expected = [m for m in models if m in PAPER_MODELS or any(c.model == m for c in found)]
    missing = [
        f"{m}-{s}-{p}" for p in schemes for m in expected for s in splits if (m, s, p) not in have
    ]
    if missing:
        log.warning(
            "%d checkpoints missing in %s (their cells stay empty): %s",
            len(missing),
            root,
            ", ".join(missing),
        )
    return found


def _reported(config: ExperimentConfig, label: str, models: Sequence[str]) -> bool:
    """Whether a run belongs to a report of ``models``: a named model's run, an ablation of
    one (its model named), a model of the forecaster interface in a report of every model."""
    if label in models or config.model_name in models:
        return True
    return is_outside_name(config.model_name) and tuple(models) == MODEL_NAMES


def subset_masks(split: str, samples: SampleSet) -> dict[str | None, np.ndarray | None]:
    """The whole test set (None) and, for univ, the paper's UNIV-N masks."""
    masks: dict[str | None, np.ndarray | None] = {None: None}
    if split == "univ":
        for definition in UNIV_N_DEFINITIONS:
            subsets = [UnivN(n, definition) for n in UNIV_N_PAPER]
            masks.update({s.name: univ_n_mask(samples, s) for s in subsets})
    return masks


def nll_subsample(count: int, cap: int, seed: int) -> np.ndarray:
    """(S,) mask of the samples whose NLL is computed: all, or ``cap`` drawn with ``seed``."""
    keep = np.ones(count, dtype=bool)
    if 0 < cap < count:
        keep[:] = False
        keep[np.random.default_rng(seed).choice(count, cap, replace=False)] = True
    return keep


# One function so that every mode, the NLL subsample and the diagnostics score the very same
# loaded test samples (their per-sample scores are paired later).
def score_checkpoint(
    entry: ReportCheckpoint,
    data_dir: Path,
    settings: ReportSettings,
    progress: bool = False,
) -> ScoredRun:
    """Per-sample scores and mean rows of one checkpoint: each mode on its test set and, for
    univ, on UNIV-N."""
    model, experiment = load_trained_model(entry.path)
    stored = (run_label(experiment), experiment.split, experiment.data.derivatives)
    if stored != (entry.model, entry.split, entry.derivatives):
        raise GrouptronError(
            f"{entry.path}: expected {entry.model} on {entry.split} ({entry.derivatives}) "
            f"but it holds {stored[0]} on {stored[1]} ({stored[2]})"
        )
    group_config = experiment.groups if uses_groups(experiment) else None
    samples, groups = load_test_set(
        data_dir,
        entry.split,
        experiment.data,
        None,
        group_config=group_config,
        use_cache=settings.use_cache,
    )
    masks = subset_masks(entry.split, samples)
    template = EvaluationResult(
        entry.split, entry.model, None, 0, 0.0, 0.0, None, None, str(entry.path), entry.derivatives
    )
    rows, by_mode = [], {}
    full_modes = tuple(m for m in settings.modes if m != "nll" and makes(model, m))
    batch, seed = settings.batch_size, settings.seed
    cache = settings.score_cache
    for scores in cached_score_samples(
        cache,
        model,
        experiment,
        samples,
        full_modes,
        batch_size=batch,
        seed=seed,
        progress=progress,
        groups=groups,
    ):
        rows += score_rows(template, scores, masks)
        by_mode[scores.mode] = scores
    keep = None
    if "nll" in settings.modes:
        keep = nll_subsample(len(samples), settings.nll_max_samples, seed)
        some, some_groups = subset_with_groups(samples, groups, keep)
        (scores,) = cached_score_samples(
            cache,
            model,
            experiment,
            some,
            ("nll",),
            batch_size=batch,
            seed=seed,
            progress=progress,
            groups=some_groups,
        )
        rows += score_rows(template, scores, masks, within=keep)
        by_mode["nll"] = scores
    run = ScoredRun(entry, time_step_ids(samples), masks, by_mode, keep, rows)
    if not settings.diagnostics:
        return run
    ablated = {
        ablation: cached_score_samples(
            cache,
            model,
            experiment,
            samples,
            ("ml",),
            batch_size=batch,
            progress=progress,
            groups=groups,
            ablate=(ablation,),
        )[0]
        for ablation in model.ablations
    }
    return dataclasses.replace(run, density=density_masks(samples), ablated=ablated)


def makes(model: Forecaster, mode: str) -> bool:
    """Whether ``model`` makes an evaluation mode's forecast (sampled modes: every model; a
    point forecast: one of the kinds it makes); a report leaves the others' cells empty."""
    return not is_point_forecast(mode) or PointForecast.parse(mode).kind in model.point_forecasts


def evaluate_checkpoint(
    entry: ReportCheckpoint,
    data_dir: Path,
    settings: ReportSettings,
    progress: bool = False,
) -> list[EvaluationResult]:
    """The mean rows of :func:`score_checkpoint`."""
    return score_checkpoint(entry, data_dir, settings, progress).rows


def score_constant_velocity(
    data_dir: Path,
    derivatives: DerivativeScheme,
    use_cache: bool = True,
    splits: Sequence[str] = SPLITS,
) -> list[ScoredRun]:
    """Constant velocity on every split (or those of ``splits``) and UNIV-N (its inputs are
    raw positions, so both schemes give the same numbers)."""
    config = DataConfig(derivatives=derivatives)
    runs = []
    for split in splits:
        samples, _ = load_test_set(data_dir, split, config, use_cache=use_cache)
        scores = constant_velocity_scores(samples, config.horizon_steps)
        masks = subset_masks(split, samples)
        entry = ReportCheckpoint(CONSTANT_VELOCITY, split, derivatives, Path())
        template = EvaluationResult(split, CONSTANT_VELOCITY, None, 0, 0.0, 0.0, "ml")
        template = dataclasses.replace(template, derivatives=derivatives)
        rows = score_rows(template, scores, masks)
        runs.append(ScoredRun(entry, time_step_ids(samples), masks, {"ml": scores}, None, rows))
    return runs


def run_report(
    data_dir: Path,
    checkpoints: Sequence[ReportCheckpoint],
    schemes: Sequence[DerivativeScheme],
    settings: ReportSettings,
    *,
    progress: bool = False,
    announce: bool = False,
    splits: Sequence[str] = SPLITS,
) -> Report:
    """Rows for every checkpoint and constant velocity (on ``splits``), the AVG rows (where
    all five are scored), intervals, paired differences and the seed spread.

    The lowest seed of each (model, split, derivatives) gives the table rows in every mode; the
    other seeds are scored in the ``ml`` mode for the seed spread. ``announce`` names each
    checkpoint as it starts and ``progress`` draws bars, both on standard error, so that
    standard output can carry JSON.
    """
    runs: list[ScoredRun] = []
    baseline = score_constant_velocity(data_dir, schemes[0], settings.use_cache, splits)
    for derivatives in schemes:  # the same numbers under both schemes: scored once
        runs += [
            dataclasses.replace(
                run,
                entry=dataclasses.replace(run.entry, derivatives=derivatives),
                rows=[dataclasses.replace(r, derivatives=derivatives) for r in run.rows],
            )
            for run in baseline
        ]
    first_seed: dict[tuple[str, str, str], int] = {}
    for entry in checkpoints:
        key = (entry.model, entry.split, entry.derivatives)
        first_seed.setdefault(key, entry.seed)
        primary = first_seed[key] == entry.seed
        log.info("evaluating %s", entry.path)
        if announce:
            print(
                f"{entry.model} {entry.split} ({entry.derivatives} derivatives, seed "
                f"{entry.seed}): {entry.path}",
                file=sys.stderr,
                flush=True,
            )
        run_settings = (
            settings if primary else dataclasses.replace(settings, modes=("ml",), diagnostics=False)
        )
        with torch.inference_mode():
            runs.append(score_checkpoint(entry, data_dir, run_settings, progress))
    return build_report(runs, schemes)
