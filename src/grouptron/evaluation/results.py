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
from grouptron.evaluation.uncertainty import mean_interval

MEAN_ROW = "mean"
NAMED = ("ade", "fde", metrics.NLL)
"""Metrics with a field of their own in a row (the paper's tables read them by name); every
other registered metric is in ``EvaluationResult.metrics``."""


@dataclass(frozen=True)
class EvaluationResult:
    """Scores of one model on one split (or subset), averaged over its test samples.

    ``mode`` names the prediction (``ml``, ``ml-argmax``, ``best-of-20``, ``nll``) for models
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

    def to_dict(self) -> dict[str, object]:
        """The row as JSON values: optional fields left out where unset, every other metric
        beside ADE and FDE (``miss_2m``, with ``miss_2m_ci``), NaN as None."""
        row = dataclasses.asdict(self)
        for optional in ("mode", "nll", "checkpoint", "derivatives", "ade_ci", "fde_ci"):
            if row[optional] is None:
                del row[optional]
        extra, intervals = row.pop("metrics"), row.pop("metrics_ci")
        for name, value in extra.items():
            row[name] = value
            if name in intervals:
                row[f"{name}_ci"] = intervals[name]
        return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}


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
    (time steps resampled). ``within`` (S,): the samples ``scores`` cover where they cover
    only some (the NLL subsample); the masks are narrowed to it. ``named_mode`` False leaves
    ``mode`` unset (constant velocity's one forecast). The one place scores become rows."""
    rows = []
    for subset, keep in masks.items():
        mask = keep if keep is None or within is None else keep[within]
        kept = scores if mask is None else scores.subset(mask)
        summary = kept.summary()
        intervals: dict[str, tuple[float, float]] = {}
        if steps is not None and len(kept):
            kept_steps = steps if mask is None else steps[mask]
            for name, values in kept.values.items():
                found = mean_interval(values, kept_steps)
                intervals[name] = (found.low, found.high)
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
                metrics={k: v for k, v in summary.means.items() if k not in NAMED},
                metrics_ci={k: v for k, v in intervals.items() if k not in NAMED},
            )
        )
    return rows


def mean_over_splits(results: Sequence[EvaluationResult]) -> EvaluationResult:
    """The unweighted mean of split scores (the papers' "AVG" column)."""
    first = results[0]
    nll = [r.nll for r in results if r.nll is not None]
    return dataclasses.replace(
        first,
        split=MEAN_ROW,
        samples=sum(r.samples for r in results),
        ade=float(np.mean([r.ade for r in results])),
        fde=float(np.mean([r.fde for r in results])),
        nll=float(np.mean(nll)) if len(nll) == len(results) else None,
        checkpoint=None,
        ade_ci=None,
        fde_ci=None,
    )


def results_json(results: Sequence[EvaluationResult]) -> str:
    """The rows as a JSON document ``{"results": [...]}``, NaN written as null."""
    return json.dumps({"results": [r.to_dict() for r in results]}, indent=2)


def _fmt(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.3f}"


def results_table(results: Sequence[EvaluationResult]) -> str:
    """A fixed-width text table: split (or file), subset, model, samples, ADE, FDE (metres),
    NLL, every other registered metric, and the 95% interval of FDE where one was computed."""
    with_nll = any(r.nll is not None for r in results)
    extra = list(dict.fromkeys(name for r in results for name in r.metrics))
    labels = [metrics.METRICS[n].label if n in metrics.METRICS else n for n in extra]
    with_ci = any(r.fde_ci is not None for r in results)
    width = max([7, *(len(r.split) for r in results)])
    sub = max([9, *(len(r.subset or "") for r in results)])
    model = max([30, *(len(r.model) + len(r.mode or "") + 3 for r in results)])
    header = (
        f"{'split':<{width}} {'subset':<{sub}} {'model':<{model}} {'samples':>8} {'ADE m':>7} "
        f"{'FDE m':>7}"
    )
    header += f" {'NLL':>7}" if with_nll else ""
    header += "".join(f" {label:>{max(7, len(label))}}" for label in labels)
    header += f" {'FDE 95% interval':>18}" if with_ci else ""
    lines = [header, "-" * len(header)]
    for r in results:
        name = r.model if r.mode is None else f"{r.model} ({r.mode})"
        line = (
            f"{r.split:<{width}} {r.subset or '-':<{sub}} {name:<{model}} {r.samples:>8} "
            f"{_fmt(r.ade):>7} {_fmt(r.fde):>7}"
        )
        line += f" {_fmt(r.nll):>7}" if with_nll else ""
        line += "".join(
            f" {_fmt(r.metrics.get(n)):>{max(7, len(label))}}"
            for n, label in zip(extra, labels, strict=True)
        )
        if with_ci:
            interval = f"[{_fmt(r.fde_ci[0])}, {_fmt(r.fde_ci[1])}]" if r.fde_ci else "-"
            line += f" {interval:>18}"
        lines.append(line)
    return "\n".join(lines)
