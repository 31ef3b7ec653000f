"""Evaluation results: one row per (split, model, subset, mode), as a table or JSON."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import SampleScores
from grouptron.evaluation.uncertainty import column_intervals

MEAN_ROW = "mean"
NAMED = ("ade", "fde", metrics.NLL)
"""Metrics with a field of their own in a row (the paper's tables read them by name); every
other registered metric is in ``EvaluationResult.metrics``."""


@dataclass(frozen=True)
class EvaluationResult:
    """Scores of one model on one split (or subset), averaged over its test samples.

    ``mode`` names the prediction (``ml``, ``ml-argmax``, ``best-of-K``, ``nll``) for models
    with several; ``nll`` is the KDE NLL in nats (``nll`` mode only); values that a mode does not
    define are NaN here and ``null`` in JSON.
    """

    split: str
    model: str
    subset: str | None
    samples: int
    ade: float
    fde: float
    mode: str | None = None
    nll: float | None = None
    checkpoint: str | None = None
    derivatives: str | None = None
    """The derivative scheme of the inputs: ``central`` (the papers') or ``backward``."""
    ade_ci: tuple[float, float] | None = None
    """95% bootstrap interval of the mean ADE (time steps resampled), where computed."""
    fde_ci: tuple[float, float] | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    """Means of the registered metrics other than ADE and FDE, by name."""
    metrics_ci: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Their 95% intervals, where computed."""
    per_step: dict[str, tuple[float, ...]] = field(default_factory=dict)
    """The (H,) per-step means of the metrics scored per step: the displacement error
    (``displacement``) and the region metrics (their mean over the steps is in ``metrics``)."""
    nll_ci: tuple[float, float] | None = None
    """95% interval of the mean NLL (of the samples where it is defined), where computed."""
    per_step_ci: dict[str, tuple[tuple[float, float], ...]] = field(default_factory=dict)
    """The 95% interval of each per-step mean, where computed."""
    held_out: bool = True
    """False where the scored samples are not held out from the checkpoint: it trained or
    validated on them (``evaluate`` scores such data only when asked, and says so)."""

    def to_dict(self) -> dict[str, object]:
        """The row as JSON values: optional fields left out where unset, every other metric
        beside ADE and FDE (``miss-rate-2m``, with ``miss-rate-2m_ci``), every metric kept per
        step as its list of step means (``displacement_per_step``, ``coverage-q90_per_step``,
        with ``displacement_per_step_ci``), NaN as None."""
        row = dataclasses.asdict(self)
        for optional in OPTIONAL:
            if row[optional] is None:
                del row[optional]
        if row["held_out"]:  # named where it is not: ``held_out: false``
            del row["held_out"]
        extra, intervals = row.pop("metrics"), row.pop("metrics_ci")
        per_step, step_intervals = row.pop("per_step"), row.pop("per_step_ci")
        for name, value in extra.items():
            row[name] = value
            if name in intervals:
                row[f"{name}_ci"] = intervals[name]
        for name, values in per_step.items():
            row[f"{name}{PER_STEP}"] = [_json_number(v) for v in values]
            if name in step_intervals:
                row[f"{name}{PER_STEP}_ci"] = [list(ci) for ci in step_intervals[name]]
        return {k: _json_number(v) if isinstance(v, float) else v for k, v in row.items()}


OPTIONAL = ("mode", "nll", "checkpoint", "derivatives", "ade_ci", "fde_ci", "nll_ci")
"""Fields a row's JSON leaves out where unset."""


PER_STEP = "_per_step"
"""The suffix of a metric's per-step means in JSON."""
TABLE_STEPS = (4, 8, 12)
"""The forecast steps (1.6, 3.2 and 4.8 s ahead) whose per-step means a table shows."""


def _json_number(value: float) -> float | None:
    return None if math.isnan(value) else value


def score_rows(
    template: EvaluationResult,
    scores: SampleScores,
    masks: Mapping[str | None, np.ndarray | None],
    *,
    steps: np.ndarray | None = None,
    within: np.ndarray | None = None,
    named_mode: bool = True,
) -> list[EvaluationResult]:
    """One row per subset (its name in ``subset``; a None mask is every sample) with the mean
    of every metric ``scores`` hold. ``steps`` (S,): time-step ids, to add 95% intervals
    (time steps resampled) to every mean, per step too. ``within`` (S,): the samples
    ``scores`` cover where they cover only some (the NLL subsample); the masks are narrowed to
    it. ``named_mode`` False leaves ``mode`` unset (constant velocity's one forecast). The one
    place scores become rows."""
    rows = []
    for subset, keep in masks.items():
        mask = keep if keep is None or within is None else keep[within]
        kept = scores if mask is None else scores.subset(mask)
        summary = kept.summary()
        intervals: dict[str, tuple[float, float]] = {}
        step_intervals: dict[str, tuple[tuple[float, float], ...]] = {}
        if steps is not None and len(kept):
            kept_steps = steps if mask is None else steps[mask]
            intervals, step_intervals = _intervals([(kept, kept_steps)])
        rows.append(
            dataclasses.replace(
                template,
                subset=subset,
                samples=summary.samples,
                ade=summary.ade,
                fde=summary.fde,
                mode=scores.mode if named_mode else None,
                nll=summary.nll if scores.mode == metrics.NLL else None,
                ade_ci=intervals.get("ade"),
                fde_ci=intervals.get("fde"),
                nll_ci=intervals.get(metrics.NLL),
                metrics={k: v for k, v in summary.means.items() if k not in NAMED},
                metrics_ci={k: v for k, v in intervals.items() if k not in NAMED},
                per_step=summary.step_means,
                per_step_ci=step_intervals,
            )
        )
    return rows


def _intervals(
    per_split: Sequence[tuple[SampleScores, np.ndarray]],
) -> tuple[dict[str, tuple[float, float]], dict[str, tuple[tuple[float, float], ...]]]:
    """95% intervals of every mean and every per-step mean of the scores of one split, or of
    the unweighted mean over several (each split's time steps resampled), from (scores, (S,)
    time-step ids) pairs; the NLL's over the samples where it is defined."""
    first = per_split[0][0]
    means: dict[str, tuple[float, float]] = {}
    for name in first.values:
        pairs = [(s.values[name], t) for s, t in per_split]
        if name == metrics.NLL:  # its mean leaves out the samples without a KDE
            pairs = [(v[~np.isnan(v)], t[~np.isnan(v)]) for v, t in pairs]
        if all(len(v) for v, _ in pairs):
            (found,) = column_intervals([(v[:, None], t) for v, t in pairs])
            means[name] = (found.low, found.high)
    stepped: dict[str, tuple[tuple[float, float], ...]] = {}
    for name in first.per_step:
        found_steps = column_intervals([(s.per_step[name], t) for s, t in per_split])
        stepped[name] = tuple((i.low, i.high) for i in found_steps)
    return means, stepped


def mean_over_splits(
    results: Sequence[EvaluationResult],
    scored: Sequence[tuple[SampleScores, np.ndarray]] | None = None,
) -> EvaluationResult:
    """The unweighted mean of split scores (the papers' "AVG" column), of every metric all
    splits hold (per step too); with the splits' ``scored`` (scores, (S,) time-step ids), in
    the order of ``results``, the 95% interval of every mean (each split resampled on its own
    time steps, as the report's AVG)."""
    first = results[0]
    nll = [r.nll for r in results if r.nll is not None]
    shared = [n for n in first.metrics if all(n in r.metrics for r in results)]
    stepped = [n for n in first.per_step if all(n in r.per_step for r in results)]
    intervals, step_intervals = _intervals(scored) if scored else ({}, {})
    return dataclasses.replace(
        first,
        split=MEAN_ROW,
        held_out=all(r.held_out for r in results),
        samples=sum(r.samples for r in results),
        ade=float(np.mean([r.ade for r in results])),
        fde=float(np.mean([r.fde for r in results])),
        nll=float(np.mean(nll)) if len(nll) == len(results) else None,
        checkpoint=None,
        ade_ci=intervals.get("ade"),
        fde_ci=intervals.get("fde"),
        nll_ci=intervals.get(metrics.NLL),
        metrics={n: float(np.mean([r.metrics[n] for r in results])) for n in shared},
        metrics_ci={n: v for n, v in intervals.items() if n in shared},
        per_step={
            n: tuple(float(v) for v in np.mean([r.per_step[n] for r in results], axis=0))
            for n in stepped
        },
        per_step_ci={n: v for n, v in step_intervals.items() if n in stepped},
    )


def results_json(results: Sequence[EvaluationResult]) -> str:
    """The rows as a JSON document ``{"results": [...]}``, NaN written as null; every row
    names every metric a row has (null where it has none: constant velocity's regions)."""
    rows = [r.to_dict() for r in results]
    names = [n for r in results for n in r.metrics]
    names += [f"{n}{PER_STEP}" for r in results for n in r.per_step]
    for row in rows:
        for name in dict.fromkeys(names):
            row.setdefault(name, None)
    return json.dumps({"results": rows}, indent=2)


def _fmt(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.3f}"


def results_table(results: Sequence[EvaluationResult]) -> str:
    """A fixed-width text table: split (or file), subset, model, samples, ADE, FDE (metres),
    NLL, the displacement error at steps 4, 8 and 12 (``DE m @4``), every other registered
    metric (a region metric at steps 4, 8 and 12 and its mean over the steps), and the 95%
    interval of FDE where one was computed (JSON holds every step and every interval)."""
    with_nll = any(r.nll is not None for r in results)
    columns = _metric_columns(results)
    with_ci = any(r.fde_ci is not None for r in results)
    width = max([7, *(len(r.split) for r in results)])
    sub = max([9, *(len(r.subset or "") for r in results)])
    model = max([30, *(len(_name(r)) + (3 if r.mode is None else 0) for r in results)])
    header = (
        f"{'split':<{width}} {'subset':<{sub}} {'model':<{model}} {'samples':>8} {'ADE m':>7} "
        f"{'FDE m':>7}"
    )
    header += f" {'NLL':>7}" if with_nll else ""
    header += "".join(f" {label:>{max(7, len(label))}}" for label, _, _ in columns)
    header += f" {'FDE 95% interval':>18}" if with_ci else ""
    lines = [header, "-" * len(header)]
    for r in results:
        name = _name(r)
        line = (
            f"{r.split:<{width}} {r.subset or '-':<{sub}} {name:<{model}} {r.samples:>8} "
            f"{_fmt(r.ade):>7} {_fmt(r.fde):>7}"
        )
        line += f" {_fmt(r.nll):>7}" if with_nll else ""
        line += "".join(
            f" {_fmt(_cell(r, n, step)):>{max(7, len(label))}}" for label, n, step in columns
        )
        if with_ci:
            interval = f"[{_fmt(r.fde_ci[0])}, {_fmt(r.fde_ci[1])}]" if r.fde_ci else "-"
            line += f" {interval:>18}"
        lines.append(line)
    return "\n".join(lines)


NOT_HELD_OUT = "not held out"
"""How a table marks a row scored on data the checkpoint trained or validated on."""


def _name(row: EvaluationResult) -> str:
    """A row's model in a table: with its mode, and marked where it is not held out."""
    name = row.model if row.mode is None else f"{row.model} ({row.mode})"
    return name if row.held_out else f"{name} [{NOT_HELD_OUT}]"


def _metric_columns(results: Sequence[EvaluationResult]) -> list[tuple[str, str, int | None]]:
    """(heading, metric name, step or None for the mean) of every column after ADE and FDE:
    each metric's mean, a metric scored per step at :data:`TABLE_STEPS` first; one kept per
    step only (the displacement error) at those steps alone, before the others."""
    columns: list[tuple[str, str, int | None]] = []
    averaged = [n for r in results for n in r.metrics]
    stepped = [n for r in results for n in r.per_step if n not in averaged]
    for name in dict.fromkeys([*stepped, *averaged]):
        label = metrics.metric_label(name)
        horizon = max((len(r.per_step[name]) for r in results if name in r.per_step), default=0)
        columns += [(f"{label} @{s}", name, s) for s in TABLE_STEPS if s <= horizon]
        if name in averaged:
            columns.append((label, name, None))
    return columns


def _cell(row: EvaluationResult, name: str, step: int | None) -> float | None:
    """A row's mean of metric ``name``, or its mean at (1-based) ``step``; None where unset."""
    if step is None:
        return row.metrics.get(name)
    values = row.per_step.get(name)
    return values[step - 1] if values is not None and step <= len(values) else None
