"""What a model uses and where it fails: the report's density and ablation tables.

Both compare most likely (ML) FDEs on the same test samples, so every cell is a paired
difference with a 95% interval over resampled time steps:

- *by density*: model minus constant velocity in each density bin (neighbours within 3 m at
  the forecast step), the five test sets pooled (their time steps kept apart);
- *ablations*: the model with one input taken away (``edges``: the edge encoder's neighbour
  input; ``scene``: Grouptron's E_scene) minus the intact model, per split.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grouptron.constants import CONSTANT_VELOCITY, SPLITS
from grouptron.evaluation.scored import ScoredRun
from grouptron.evaluation.uncertainty import Interval, mean_interval

BOOTSTRAP_SEED = 0


@dataclass(frozen=True)
class DensityRow:
    """Model minus constant velocity ML FDE (m) on the samples of one density bin."""

    model: str
    derivatives: str
    bin: str
    samples: int
    fde: float
    fde_constant_velocity: float
    difference: Interval

    def to_dict(self) -> dict[str, object]:
        """The row as a dict (the interval as ``{mean, low, high}``)."""
        return dataclasses.asdict(self)  # the Interval becomes a {mean, low, high} dict


@dataclass(frozen=True)
class AblationRow:
    """Ablated minus intact ML FDE (m) of one checkpoint on its split's test set."""

    model: str
    derivatives: str
    ablation: str
    split: str
    samples: int
    fde: float
    fde_ablated: float
    difference: Interval

    def to_dict(self) -> dict[str, object]:
        """The row as a dict (the interval as ``{mean, low, high}``)."""
        return dataclasses.asdict(self)  # the Interval becomes a {mean, low, high} dict


def density_rows(primary: Sequence[ScoredRun]) -> list[DensityRow]:
    """One row per (model, derivatives, density bin) over the splits the model has; constant
    velocity is the baseline on the same samples (runs without density masks are skipped)."""
    baseline = {
        (r.entry.split, r.entry.derivatives): r
        for r in primary
        if r.entry.model == CONSTANT_VELOCITY
    }
    models = [r for r in primary if r.entry.model != CONSTANT_VELOCITY and r.density]
    rows = []
    for model, derivatives in dict.fromkeys((r.entry.model, r.entry.derivatives) for r in models):
        runs = [r for r in models if (r.entry.model, r.entry.derivatives) == (model, derivatives)]
        for name in runs[0].density:
            parts = [
                _bin_values(run, baseline[run.entry.split, derivatives], name, SPLITS.index(s))
                for run in runs
                if (s := run.entry.split) in SPLITS and (s, derivatives) in baseline
            ]
            model_fde, cv_fde, steps = (np.concatenate(v) for v in zip(*parts, strict=True))
            if len(steps) == 0:
                continue
            difference = mean_interval(model_fde - cv_fde, steps, seed=BOOTSTRAP_SEED)
            rows.append(
                DensityRow(
                    model,
                    derivatives,
                    name,
                    len(steps),
                    float(model_fde.mean()),
                    float(cv_fde.mean()),
                    difference,
                )
            )
    return rows


def _bin_values(
    run: ScoredRun, baseline: ScoredRun, name: str, split_index: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n,) model FDE, constant velocity FDE and time steps (unique across splits) in a bin."""
    keep = run.density[name]
    # Time steps of different splits must stay different clusters.
    steps = run.steps[keep].astype(np.int64) * len(SPLITS) + split_index
    return run.scores["ml"].fde[keep], baseline.scores["ml"].fde[keep], steps


def ablation_rows(primary: Sequence[ScoredRun]) -> list[AblationRow]:
    """One row per checkpoint and ablation it was scored with."""
    rows = []
    for run in primary:
        intact = run.scores.get("ml")
        for ablation, scores in run.ablated.items():
            if intact is None:
                continue
            difference = mean_interval(scores.fde - intact.fde, run.steps, seed=BOOTSTRAP_SEED)
            rows.append(
                AblationRow(
                    run.entry.model,
                    run.entry.derivatives,
                    ablation,
                    run.entry.split,
                    len(run.steps),
                    float(intact.fde.mean()),
                    float(scores.fde.mean()),
                    difference,
                )
            )
    return rows


def diagnostics_markdown(
    density: Sequence[DensityRow], ablations: Sequence[AblationRow], display: dict[str, str]
) -> list[str]:
    """The two sections (empty when the report was made without ``--diagnostics``)."""
    out: list[str] = []
    if density:
        bins = list(dict.fromkeys(r.bin for r in density))
        counts = {r.bin: r.samples for r in density}
        out += [
            "",
            "## By density",
            "",
            "Most likely FDE minus constant velocity's (m) on the same test samples, the five",
            "test sets pooled, by neighbours within 3 m at the forecast step; 95% interval over",
            "resampled time steps; `*`: the interval excludes zero; negative: the model is better.",
            "",
            "| model | derivatives | " + " | ".join(f"{b} ({counts[b]})" for b in bins) + " |",
            "|---|---|" + "---|" * len(bins),
        ]
        cells = {(r.model, r.derivatives, r.bin): r.difference.signed_text() for r in density}
        for model, derivatives in dict.fromkeys((r.model, r.derivatives) for r in density):
            row = [cells.get((model, derivatives, b), "-") for b in bins]
            out.append(f"| {display.get(model, model)} | {derivatives} | " + " | ".join(row) + " |")
    if ablations:
        splits = [s for s in SPLITS if any(r.split == s for r in ablations)]
        out += [
            "",
            "## Ablations",
            "",
            "Most likely FDE with one input taken away minus the intact model's (m), same test",
            "samples: `edges` zeroes the edge encoder's neighbour input, `scene` Grouptron's",
            "E_scene; 95% interval over resampled time steps; positive: the model uses the input.",
            "",
            "| model | derivatives | taken away | " + " | ".join(s.upper() for s in splits) + " |",
            "|---|---|---|" + "---|" * len(splits),
        ]
        changes = {
            (r.model, r.derivatives, r.ablation, r.split): f"{r.difference.signed_text()} "
            f"({100 * (r.fde_ablated / r.fde - 1):+.1f}%)"
            for r in ablations
        }
        keys = dict.fromkeys((r.model, r.derivatives, r.ablation) for r in ablations)
        for model, derivatives, ablation in keys:
            row = [changes.get((model, derivatives, ablation, s), "-") for s in splits]
            name = display.get(model, model)
            out.append(f"| {name} | {derivatives} | {ablation} | " + " | ".join(row) + " |")
    return out
