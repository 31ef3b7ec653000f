"""The report of a dataset of one's own (a benchmark of one's own, such as TrajNet's Stanford
Drone scenes): every checkpoint trained on it and constant velocity on its test part, with 95%
intervals (time steps resampled), and every row's paired FDE difference to the best row of its
mode."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.custom import DatasetDescription, load_dataset_part
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores
from grouptron.evaluation.results import NAMED, EvaluationResult, results_json, score_rows
from grouptron.evaluation.score_cache import cached_score_samples
from grouptron.evaluation.uncertainty import Interval, mean_interval
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


@dataclass(frozen=True)
class ToBest:
    """One row's mean FDE minus the best row's of its derivatives and mode, on the same
    samples (the best row's own is 0).

    Attributes:
        derivatives: the rows' derivatives, numbered (``backward, sample set 2``) where runs
            of the same derivatives differ in their test samples (other data settings).
        row: the row's model and mode as the table names them.
        best: the best row's.
        fde: the mean difference in metres with its 95% interval (time steps resampled).
    """

    derivatives: str
    row: str
    best: str
    fde: Interval


@dataclass(frozen=True)
class DatasetReport:
    """The rows of a dataset's report and every row's difference to the best."""

    rows: list[EvaluationResult]
    to_best: list[ToBest]


_Scored = dict[tuple[str, str], tuple[str, np.ndarray, np.ndarray]]
"""(sample set: the derivatives, numbered where runs differ in their test samples, row name)
-> (its kind of forecast, (S,) per-sample FDE, (S,) time-step ids)."""


def dataset_report(
    dataset: DatasetDescription,
    root: Path,
    *,
    modes: tuple[str, ...] = ("ml",),
    seed: int = 0,
    use_cache: bool = True,
    score_cache: Path | None = None,
) -> DatasetReport:
    """Rows for constant velocity (once per set of test samples: the runs' data settings
    decide it) and every checkpoint, and every row's difference to the best row on the same
    samples; ``score_cache`` keeps per-sample scores between runs (None: not kept)."""
    rows: list[EvaluationResult] = []
    scored_fde: _Scored = {}
    sample_sets: dict[str, str] = {}  # samples' digest -> the label rows on them share
    for path in checkpoints_of(dataset, root):
        model, experiment = load_trained_model(path)
        data = experiment.data
        samples = load_dataset_part(dataset, "test", data, use_cache=use_cache).samples
        steps = time_step_ids(samples)
        template = EvaluationResult(dataset.name, CONSTANT_VELOCITY, None, 0, 0.0, 0.0)
        template = dataclasses.replace(template, derivatives=data.derivatives)
        digest = _sample_digest(samples, data.derivatives)
        if digest not in sample_sets:
            same = sum(label.startswith(data.derivatives) for label in sample_sets.values())
            sample_sets[digest] = data.derivatives + (f", sample set {same + 1}" if same else "")
            cv = constant_velocity_scores(samples, data.horizon_steps)
            rows += score_rows(template, cv, {None: None}, steps=steps)
            _keep(scored_fde, sample_sets[digest], CONSTANT_VELOCITY, cv, steps)
        groups = groups_for_model(samples, experiment)
        ours = dataclasses.replace(template, model=experiment.model_name, checkpoint=str(path))
        scored = cached_score_samples(
            score_cache, model, experiment, samples, modes, seed=seed, groups=groups
        )
        for scores in scored:
            rows += score_rows(ours, scores, {None: None}, steps=steps)
            label = f"{experiment.model_name} ({scores.mode}), {path.parent.name}"
            _keep(scored_fde, sample_sets[digest], label, scores, steps)
    return DatasetReport(rows, differences_to_best(scored_fde))


def _sample_digest(samples: SampleSet, derivatives: str) -> str:
    """Which test samples these are, in order (their scene, step and person) and with which
    derivatives: rows are paired sample by sample only within one digest."""
    keys = np.stack([samples.scene_index, samples.step, samples.track]).astype(np.int64)
    return hashlib.sha256(keys.tobytes() + derivatives.encode()).hexdigest()


def _keep(
    found: _Scored, sample_set: str, name: str, scores: SampleScores, steps: np.ndarray
) -> None:
    """Keep a row's per-sample FDE: one forecast (``ml``, any point forecast) or best-of-K."""
    kind = scores.mode if scores.mode.startswith("best-of-") else "one forecast"
    if scores.mode != metrics.NLL:
        found[sample_set, name] = (kind, scores.fde, steps)


def differences_to_best(scored: _Scored) -> list[ToBest]:
    """Every row minus the row of lowest mean FDE among those of its sample set and kind of
    forecast (one forecast, constant velocity's included, or best-of-K), sample by sample."""
    out = []
    kinds = dict.fromkeys((d, kind) for (d, _), (kind, _, _) in scored.items())
    for derivatives, kind in kinds:
        mine = {n: v for (d, n), v in scored.items() if d == derivatives and v[0] == kind}
        best = min(mine, key=lambda n: float(np.mean(mine[n][1])) if len(mine[n][1]) else math.inf)
        _, best_fde, steps = mine[best]
        for name, (_, fde, _) in mine.items():
            interval = mean_interval(fde - best_fde, steps, seed=0)
            out.append(ToBest(derivatives, name, best, interval))
    return out


def dataset_json(report: DatasetReport) -> str:
    """The rows as ``results_json`` writes them, with ``to_best``: every row's FDE minus the
    best's, its interval and the best row's name."""
    document = json.loads(results_json(report.rows))
    document["to_best"] = [
        {
            "derivatives": d.derivatives,
            "row": d.row,
            "best": d.best,
            "fde": d.fde.mean,
            "fde_ci": d.fde.to_list(),
        }
        for d in report.to_best
    ]
    return json.dumps(document, indent=2)


def dataset_markdown(dataset: DatasetDescription, report: DatasetReport) -> str:
    """The rows as a Markdown table: every metric's mean with its 95% interval (ADE, FDE,
    then the other registered metrics in order); then every row against the best."""
    rows = report.rows
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
    if report.to_best:
        lines += [
            "",
            "Mean FDE (m) minus the best row's of the same kind of forecast (one forecast, or",
            "best of K) on the same test samples, with its 95% interval over resampled time",
            "steps; `*`: the interval excludes zero.",
            "",
        ]
        lines += [
            "| model (mode) | derivatives | best | FDE - best's [95% interval] |",
            "|---|---|---|---|",
        ]
        for d in report.to_best:
            cell = "**best**" if d.row == d.best else d.fde.signed_text()
            lines.append(f"| {d.row} | {d.derivatives} | {d.best} | {cell} |")
    return "\n".join(lines) + "\n"


def _with_interval(mean: float, interval: tuple[float, float] | None) -> str:
    low, high = interval or (float("nan"), float("nan"))
    return f"{mean:.3f} [{low:.3f}, {high:.3f}]"
