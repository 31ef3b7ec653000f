"""Evaluation results: one row per (split, model, subset), printable as a table or JSON."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grouptron.data.samples import SampleSet
from grouptron.evaluation.metrics import ade, fde

MEAN_ROW = "mean"


@dataclass(frozen=True)
class EvaluationResult:
    """Scores of one model on one split (or subset), averaged over its test samples."""

    split: str
    model: str
    subset: str | None
    samples: int
    ade: float
    fde: float
    mode: str | None = None

    def to_dict(self) -> dict[str, object]:
        row = dataclasses.asdict(self)
        if row["mode"] is None:
            del row["mode"]
        return row


def score(
    split: str,
    model: str,
    subset: str | None,
    pred_rel_m: np.ndarray,
    samples: SampleSet,
    mode: str | None = None,
) -> EvaluationResult:
    """Mean ADE/FDE of (S, H, 2) predictions against the samples' futures."""
    truth = samples.fut_rel_m.astype(np.float64)
    return EvaluationResult(
        split=split,
        model=model,
        subset=subset,
        samples=len(samples),
        ade=float(ade(pred_rel_m, truth).mean()) if len(samples) else math.nan,
        fde=float(fde(pred_rel_m, truth).mean()) if len(samples) else math.nan,
        mode=mode,
    )


def mean_over_splits(results: Sequence[EvaluationResult]) -> EvaluationResult:
    """The unweighted mean of split scores (the papers' "AVG" column)."""
    first = results[0]
    return EvaluationResult(
        split=MEAN_ROW,
        model=first.model,
        subset=first.subset,
        samples=sum(r.samples for r in results),
        ade=float(np.mean([r.ade for r in results])),
        fde=float(np.mean([r.fde for r in results])),
        mode=first.mode,
    )


def results_json(results: Sequence[EvaluationResult]) -> str:
    return json.dumps({"results": [r.to_dict() for r in results]}, indent=2)


def results_table(results: Sequence[EvaluationResult]) -> str:
    """A fixed-width text table: split, subset, model, samples, ADE, FDE (metres)."""
    header = f"{'split':<7} {'subset':<9} {'model':<18} {'samples':>8} {'ADE m':>7} {'FDE m':>7}"
    lines = [header, "-" * len(header)]
    for r in results:
        name = r.model if r.mode is None else f"{r.model} ({r.mode})"
        lines.append(
            f"{r.split:<7} {r.subset or '-':<9} {name:<18} {r.samples:>8} "
            f"{r.ade:>7.3f} {r.fde:>7.3f}"
        )
    return "\n".join(lines)
