"""The report of a dataset of one's own: every checkpoint trained on it and constant velocity
on its test part, with 95% intervals (time steps resampled)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from grouptron.data.custom import DatasetDescription, load_dataset_part
from grouptron.data.subsets import time_step_ids
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores
from grouptron.evaluation.results import EvaluationResult
from grouptron.evaluation.score_cache import cached_score_samples
from grouptron.evaluation.uncertainty import mean_interval
from grouptron.model.checkpoint import load_trained_model, stored_checkpoints
from grouptron.model.factory import groups_for_model


def checkpoints_of(dataset: DatasetDescription, root: Path) -> list[Path]:
    """The ``*/best.safetensors`` under ``root`` whose stored configuration names this
    dataset's description file."""
    found = [
        path
        for path, config in stored_checkpoints(root)
        if config.dataset and Path(config.dataset).resolve() == dataset.source
    ]
    if not found:
        raise GrouptronError(
            f"no checkpoint under {root} was trained on {dataset.name} ({dataset.source})"
        )
    return found


def _row(template: EvaluationResult, scores: SampleScores, steps: np.ndarray) -> EvaluationResult:
    ade, fde = mean_interval(scores.ade, steps), mean_interval(scores.fde, steps)
    return dataclasses.replace(
        template,
        samples=len(scores.fde),
        ade=ade.mean,
        fde=fde.mean,
        mode=scores.mode,
        ade_ci=(ade.low, ade.high),
        fde_ci=(fde.low, fde.high),
    )


def dataset_report(
    dataset: DatasetDescription,
    root: Path,
    *,
    modes: tuple[str, ...] = ("ml",),
    seed: int = 0,
    use_cache: bool = True,
    score_cache: Path | None = None,
) -> list[EvaluationResult]:
    """Rows for constant velocity (once per kind of derivatives) and every checkpoint;
    ``score_cache`` keeps per-sample scores between runs (None: not kept)."""
    rows: list[EvaluationResult] = []
    paths = checkpoints_of(dataset, root)
    baselines_done: set[str] = set()
    for path in paths:
        model, experiment = load_trained_model(path)
        data = experiment.data
        samples = load_dataset_part(dataset, "test", data, use_cache=use_cache).samples
        steps = time_step_ids(samples)
        template = EvaluationResult(dataset.name, "constant-velocity", None, 0, 0.0, 0.0)
        template = dataclasses.replace(template, derivatives=data.derivatives)
        if data.derivatives not in baselines_done:
            baselines_done.add(data.derivatives)
            cv = constant_velocity_scores(samples, data.horizon_steps)
            rows.append(_row(template, cv, steps))
        groups = groups_for_model(samples, experiment)
        ours = dataclasses.replace(template, model=experiment.model_name, checkpoint=str(path))
        scored = cached_score_samples(
            score_cache, model, experiment, samples, modes, seed=seed, groups=groups
        )
        for scores in scored:
            rows.append(_row(ours, scores, steps))
    return rows
