"""The report of a dataset of one's own: every checkpoint trained on it and constant velocity
on its test part, with 95% intervals (time steps resampled)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.custom import DatasetDescription, load_dataset_part
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import constant_velocity_scores
from grouptron.evaluation.results import NAMED, EvaluationResult, score_rows
from grouptron.evaluation.score_cache import cached_score_samples
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
        template = EvaluationResult(dataset.name, CONSTANT_VELOCITY, None, 0, 0.0, 0.0)
        template = dataclasses.replace(template, derivatives=data.derivatives)
        if data.derivatives not in baselines_done:
            baselines_done.add(data.derivatives)
            cv = constant_velocity_scores(samples, data.horizon_steps)
            rows += score_rows(template, cv, {None: None}, steps=steps)
        groups = groups_for_model(samples, experiment)
        ours = dataclasses.replace(template, model=experiment.model_name, checkpoint=str(path))
        scored = cached_score_samples(
            score_cache, model, experiment, samples, modes, seed=seed, groups=groups
        )
        for scores in scored:
            rows += score_rows(ours, scores, {None: None}, steps=steps)
    return rows


def dataset_markdown(dataset: DatasetDescription, rows: list[EvaluationResult]) -> str:
    """The rows as a Markdown table: every metric's mean with its 95% interval (ADE, FDE,
    then the other registered metrics in order)."""
    extra = [m for m in metrics.METRICS.values() if m.name not in NAMED]
    headings = ["ADE m", "FDE m [95% interval]", *(f"{m.label} [95% interval]" for m in extra)]
    lines = [f"# {dataset.name}: test part of `{dataset.source}`", ""]
    lines += ["| model | derivatives | mode | samples | " + " | ".join(headings) + " |"]
    lines += ["|---" * (4 + len(headings)) + "|"]
    for r in rows:
        cells = [f"{r.ade:.3f}", _with_interval(r.fde, r.fde_ci)]
        cells += [_with_interval(r.metrics[m.name], r.metrics_ci.get(m.name)) for m in extra]
        lines.append(
            f"| {r.model} | {r.derivatives} | {r.mode or 'ml'} | {r.samples} | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(lines) + "\n"


def _with_interval(mean: float, interval: tuple[float, float] | None) -> str:
    low, high = interval or (float("nan"), float("nan"))
    return f"{mean:.3f} [{low:.3f}, {high:.3f}]"
