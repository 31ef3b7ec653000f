"""What the report scores: checkpoints found by their stored configuration, and their
per-sample scores (kept for intervals and paired differences)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grouptron.evaluation.evaluate import SampleScores
from grouptron.evaluation.results import EvaluationResult
from grouptron.geometry import DerivativeScheme


@dataclass(frozen=True)
class ReportCheckpoint:
    """One checkpoint and what its stored configuration says it is."""

    model: str
    split: str
    derivatives: DerivativeScheme
    path: Path
    seed: int = 0


@dataclass(frozen=True)
class ScoredRun:
    """Per-sample scores of one checkpoint (or constant velocity) on its split's test set.

    Attributes:
        entry: the checkpoint (for constant velocity: model ``constant-velocity``, no path).
        steps: (S,) time step (scene, step) of every test sample, for the bootstrap.
        masks: the subsets (None: the whole set) as (S,) masks.
        scores: per-sample scores by mode; the ``nll`` scores cover only ``nll_within``.
        nll_within: (S,) mask of the NLL subsample, or None.
        rows: the mean rows of every mode and subset.
        density: (S,) masks of the density bins (report diagnostics), or empty.
        ablated: ML scores with an input taken away, by ablation (report diagnostics).
    """

    entry: ReportCheckpoint
    steps: np.ndarray
    masks: dict[str | None, np.ndarray | None]
    scores: dict[str, SampleScores]
    nll_within: np.ndarray | None
    rows: list[EvaluationResult]
    density: dict[str, np.ndarray] = field(default_factory=dict)
    ablated: dict[str, SampleScores] = field(default_factory=dict)
