"""How sure the report's numbers are: intervals of every score, paired differences between
models on the same samples, and the spread over seed runs.

Works on :class:`~grouptron.evaluation.scored.ScoredRun` (per-sample scores); the bootstrap
resamples time steps (``evaluation.uncertainty``) with one fixed seed, so every interval of a
report resamples the same steps and paired differences see the same resamples.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grouptron.constants import CONSTANT_VELOCITY, SPLITS
from grouptron.evaluation.results import MEAN_ROW, EvaluationResult, mean_over_splits
from grouptron.evaluation.scored import ScoredRun
from grouptron.evaluation.uncertainty import (
    Interval,
    mean_interval,
    seed_spread,
    split_average_interval,
)
from grouptron.model.factory import GROUP_MODELS
from grouptron.point_forecast import best_of_samples, is_point_forecast
from grouptron.presets import MODELS
from grouptron.reporting.diagnostics import (
    AblationRow,
    DensityRow,
    ablation_rows,
    density_rows,
)
from grouptron.reporting.out_of_domain import OutOfDomain

BOOTSTRAP_SEED = 0
PAIRS = (
    *(
        (name, b)
        for name, spec in MODELS.items()
        for b in spec.compared_with
        if b != CONSTANT_VELOCITY
    ),
    *(
        (name, b)
        for name, spec in MODELS.items()
        for b in spec.compared_with
        if b == CONSTANT_VELOCITY
    ),
)
"""(model, baseline): the differences a reader asks about, model minus baseline."""

Values = tuple[np.ndarray, np.ndarray]  # (S,) per-sample values, (S,) time steps


@dataclass(frozen=True)
class PairedDifference:
    """Mean of ``model - baseline`` per-sample errors (metres) on the same test samples, with
    95% intervals over resampled time steps. Negative: ``model`` is better."""

    derivatives: str
    mode: str
    model: str
    baseline: str
    column: str
    samples: int
    fde: Interval
    ade: Interval

    def to_dict(self) -> dict[str, object]:
        """The difference as a dict, its intervals as ``{mean, low, high}``."""
        row = dataclasses.asdict(self)
        row["fde"], row["ade"] = _interval_dict(self.fde), _interval_dict(self.ade)
        return row


@dataclass(frozen=True)
class SeedSpread:
    """ML scores of every seed run of one model (or of a paired difference) on one column.

    ``fde_intervals``: for a paired difference, each seed's 95% interval (low, high) of its
    FDE difference over resampled time steps, in the order of ``seeds``; empty otherwise.
    """

    model: str
    derivatives: str
    column: str
    seeds: tuple[int, ...]
    fde: tuple[float, ...]
    ade: tuple[float, ...]
    fde_intervals: tuple[tuple[float, float], ...] = ()

    def to_dict(self) -> dict[str, object]:
        """The spread as a dict plus the mean and sample SD over seeds of FDE and ADE
        (``fde_mean``, ``fde_sd``, ...; the SD is None for one seed)."""
        row = dataclasses.asdict(self)
        for name in ("fde", "ade"):
            mean, sd = seed_spread(getattr(self, name))
            row[f"{name}_mean"], row[f"{name}_sd"] = mean, None if math.isnan(sd) else sd
        return row


@dataclass(frozen=True)
class Report:
    """Everything ``grouptron report`` prints."""

    rows: list[EvaluationResult]
    paired: list[PairedDifference]
    seeds: list[SeedSpread]
    to_best: list[PairedDifference] = dataclasses.field(default_factory=list)
    """Every model minus the best of its column (lowest mean FDE), per derivatives and mode."""
    density: list[DensityRow] = dataclasses.field(default_factory=list)
    ablations: list[AblationRow] = dataclasses.field(default_factory=list)
    out_of_domain: OutOfDomain | None = None

    def to_json(self) -> str:
        """The report as indented JSON: results, paired differences, seed spreads, density and
        ablation rows, and the out-of-domain section where there is one."""
        ood = self.out_of_domain
        return json.dumps(
            {
                "results": [r.to_dict() for r in self.rows],
                "paired": [p.to_dict() for p in self.paired],
                "to_best": [p.to_dict() for p in self.to_best],
                "seeds": [s.to_dict() for s in self.seeds],
                "density": [d.to_dict() for d in self.density],
                "ablations": [a.to_dict() for a in self.ablations],
                **({"out_of_domain": ood.to_dict()} if ood is not None else {}),
            },
            indent=2,
        )


def _interval_dict(value: Interval) -> dict[str, float]:
    return {"mean": value.mean, "low": value.low, "high": value.high}


def _column(row: EvaluationResult) -> str:
    return row.subset if row.subset is not None else row.split


def _key(run: ScoredRun) -> tuple[str, str, str]:
    return run.entry.model, run.entry.split, run.entry.derivatives


def primary_runs(runs: Sequence[ScoredRun]) -> dict[tuple[str, str, str], ScoredRun]:
    """The lowest-seed run of every (model, split, derivatives): the one in the tables."""
    primary: dict[tuple[str, str, str], ScoredRun] = {}
    for run in sorted(runs, key=lambda r: r.entry.seed):
        primary.setdefault(_key(run), run)
    return primary


def _values(run: ScoredRun, mode: str, column: str, metric: str) -> Values | None:
    """Per-sample ``metric`` of ``run`` on a split or subset column (None if not scored)."""
    scores = run.scores.get(mode)
    if scores is None or not (is_point_forecast(mode) or best_of_samples(mode)):  # no NLL
        return None
    mask = run.masks.get(None if column == run.entry.split else column, "absent")
    if isinstance(mask, str):
        return None
    values = getattr(scores, metric)
    keep = np.ones(len(values), dtype=bool) if mask is None else mask
    return (values[keep], run.steps[keep]) if keep.any() else None


def _interval(per_split: Sequence[Values]) -> Interval:
    """One column's interval: a split or subset, or the AVG over five splits."""
    if len(per_split) == 1:
        return mean_interval(*per_split[0], seed=BOOTSTRAP_SEED)
    return split_average_interval(per_split, seed=BOOTSTRAP_SEED)


def _per_split(
    primary: dict[tuple[str, str, str], ScoredRun],
    model: str,
    derivatives: str,
    mode: str,
    *,
    column: str,
    metric: str,
) -> list[Values] | None:
    """The values behind one cell: one split's (or subset's), or all five for AVG."""
    if column == MEAN_ROW:
        runs = [primary.get((model, split, derivatives)) for split in SPLITS]
        found = [_values(r, mode, r.entry.split, metric) for r in runs if r is not None]
        complete = [v for v in found if v is not None]
        return complete if len(complete) == len(SPLITS) else None
    split = "univ" if column.startswith("univ") else column
    run = primary.get((model, split, derivatives))
    values = None if run is None else _values(run, mode, column, metric)
    return None if values is None else [values]


def with_intervals(
    rows: Sequence[EvaluationResult], primary: dict[tuple[str, str, str], ScoredRun]
) -> list[EvaluationResult]:
    """``rows`` with 95% intervals of ADE and FDE wherever per-sample scores exist."""
    out = []
    for row in rows:
        mode, derivatives = row.mode or "ml", row.derivatives or ""
        cis = []
        for metric in ("ade", "fde"):
            values = _per_split(
                primary, row.model, derivatives, mode, column=_column(row), metric=metric
            )
            cis.append(None if values is None else _interval(values))
        out.append(
            dataclasses.replace(
                row,
                ade_ci=None if cis[0] is None else (cis[0].low, cis[0].high),
                fde_ci=None if cis[1] is None else (cis[1].low, cis[1].high),
            )
        )
    return out


def paired_differences(
    primary: dict[tuple[str, str, str], ScoredRun], columns: Sequence[str]
) -> list[PairedDifference]:
    """``model - baseline`` for every pair in :data:`PAIRS`, derivatives, mode and column."""
    out = []
    schemes = dict.fromkeys(derivatives for _, _, derivatives in primary)
    for derivatives in schemes:
        for model, baseline in PAIRS:
            modes = ("ml",) if baseline == CONSTANT_VELOCITY else ("ml", "best-of-20")
            for mode in modes:
                base_mode = "ml" if baseline == CONSTANT_VELOCITY else mode
                for column in columns:
                    found = _difference(
                        primary, (model, mode), (baseline, base_mode), derivatives, column
                    )
                    out += [found] if found is not None else []
    return out


def _difference(
    primary: dict[tuple[str, str, str], ScoredRun],
    model: tuple[str, str],
    baseline: tuple[str, str],
    derivatives: str,
    column: str,
) -> PairedDifference | None:
    """``model - baseline`` ((name, mode) each) in FDE and ADE on the samples both scored in
    ``column``, with intervals; None where either has no per-sample scores."""
    diffs = {}
    for metric in ("fde", "ade"):
        a = _per_split(primary, model[0], derivatives, model[1], column=column, metric=metric)
        b = _per_split(primary, baseline[0], derivatives, baseline[1], column=column, metric=metric)
        if a is None or b is None:
            return None
        pairs = [_minus(x, y, model[0], baseline[0]) for x, y in zip(a, b, strict=True)]
        diffs[metric] = (_interval(pairs), sum(len(x[0]) for x in a))
    fde, count = diffs["fde"]
    return PairedDifference(
        derivatives, model[1], model[0], baseline[0], column, count, fde, diffs["ade"][0]
    )


TO_BEST_MODES = ("ml", "best-of-20")
"""The forecasts every model is compared with the best in: one forecast (constant
velocity's among them), and the best of 20 (the sampling models only)."""


def differences_to_best(
    primary: dict[tuple[str, str, str], ScoredRun],
    rows: Sequence[EvaluationResult],
    columns: Sequence[str],
) -> list[PairedDifference]:
    """Each model minus the best of its column (the lowest mean FDE of that derivatives,
    mode and column), on the same samples; the best one's own line is itself (0)."""
    out = []
    for (derivatives, mode, column), found in _cells_by_column(rows, columns).items():
        best = min(found, key=lambda r: r.fde).model
        for row in found:
            difference = _difference(primary, (row.model, mode), (best, mode), derivatives, column)
            out += [difference] if difference is not None else []
    return out


def _cells_by_column(
    rows: Sequence[EvaluationResult], columns: Sequence[str]
) -> dict[tuple[str, str, str], list[EvaluationResult]]:
    """The rows of each (derivatives, mode, column) of :data:`TO_BEST_MODES` with a mean
    FDE: constant velocity (one forecast) only among the ``ml`` ones."""
    found: dict[tuple[str, str, str], list[EvaluationResult]] = {}
    for row in rows:
        mode = row.mode or "ml"  # constant velocity's one forecast
        column = _column(row)
        if mode not in TO_BEST_MODES or column not in columns or math.isnan(row.fde):
            continue
        if row.model == CONSTANT_VELOCITY and mode != "ml":
            continue
        found.setdefault((row.derivatives or "", mode, column), []).append(row)
    return found


def seed_spreads(runs: Sequence[ScoredRun], columns: Sequence[str]) -> list[SeedSpread]:
    """ML scores per seed where a (model, split, derivatives) has several seed runs, and the
    difference of each group model and Trajectron++ for the seeds run for both."""
    by_key: dict[tuple[str, str, str], list[ScoredRun]] = {}
    for run in sorted(runs, key=lambda r: r.entry.seed):
        if run.entry.model != CONSTANT_VELOCITY:
            by_key.setdefault(_key(run), []).append(run)
    out = []
    for (model, split, derivatives), seeded in by_key.items():
        if len(seeded) < 2:
            continue
        for column in _split_columns(columns, split):
            fde = [_values(r, "ml", column, "fde") for r in seeded]
            ade = [_values(r, "ml", column, "ade") for r in seeded]
            if any(v is None for v in (*fde, *ade)):
                continue
            seeds = tuple(r.entry.seed for r in seeded)
            means = [float(v[0].mean()) for v in fde if v is not None]
            ade_means = [float(v[0].mean()) for v in ade if v is not None]
            out.append(
                SeedSpread(model, derivatives, column, seeds, tuple(means), tuple(ade_means))
            )
    return out + _seed_differences(by_key, columns)


def _split_columns(columns: Sequence[str], split: str) -> list[str]:
    """The columns of one split: the split itself and its subsets (univ-40, ...)."""
    return [c for c in columns if c == split or c.startswith(f"{split}-")]


def _seed_differences(
    by_key: dict[tuple[str, str, str], list[ScoredRun]], columns: Sequence[str]
) -> list[SeedSpread]:
    """Each group model - Trajectron++ of the same seed on the same samples, for the seeds
    (at least two) run for both, with each seed's paired 95% interval of the FDE difference."""
    out = []
    for (model, split, derivatives), seeded in by_key.items():
        baseline = {r.entry.seed: r for r in by_key.get(("trajectron++", split, derivatives), [])}
        common = [r for r in seeded if r.entry.seed in baseline]
        if model not in GROUP_MODELS or len(common) < 2:
            continue
        for column in _split_columns(columns, split):
            differences = [_seed_difference(r, baseline[r.entry.seed], column) for r in common]
            if any(d is None for d in differences):
                continue
            found = [d for d in differences if d is not None]
            out.append(
                SeedSpread(
                    f"{model} - trajectron++",
                    derivatives,
                    column,
                    tuple(r.entry.seed for r in common),
                    tuple(fde.mean for fde, _ in found),
                    tuple(ade for _, ade in found),
                    tuple((fde.low, fde.high) for fde, _ in found),
                )
            )
    return out


def _seed_difference(
    run: ScoredRun, baseline: ScoredRun, column: str
) -> tuple[Interval, float] | None:
    """``run - baseline`` on one column: the FDE difference with its paired interval and the
    mean ADE difference (None where either was not scored there)."""
    fde, ade = _values(run, "ml", column, "fde"), _values(run, "ml", column, "ade")
    fde_base, ade_base = (_values(baseline, "ml", column, m) for m in ("fde", "ade"))
    if fde is None or ade is None or fde_base is None or ade_base is None:
        return None
    names = run.entry.model, baseline.entry.model
    interval = mean_interval(*_minus(fde, fde_base, *names), seed=BOOTSTRAP_SEED)
    return interval, float(_minus(ade, ade_base, *names)[0].mean())


def _minus(values: Values, base: Values, model: str, baseline: str) -> Values:
    """Per-sample ``values - base`` with the time steps, on the same samples of one column."""
    if len(values[0]) != len(base[0]):
        raise ValueError(f"{model} and {baseline} scored other samples")
    return values[0] - base[0], values[1]


def with_split_means(rows: list[EvaluationResult]) -> list[EvaluationResult]:
    """``rows`` plus the AVG row of every (model, derivatives, mode) scored on all five splits."""
    means = []
    keys = dict.fromkeys((r.model, r.derivatives, r.mode) for r in rows if r.subset is None)
    for model, derivatives, mode in keys:
        per_split = [
            r
            for r in rows
            if (r.model, r.derivatives, r.mode, r.subset) == (model, derivatives, mode, None)
        ]
        if sorted(r.split for r in per_split) == sorted(SPLITS):
            means.append(mean_over_splits(per_split))
    return rows + means


def build_report(runs: Sequence[ScoredRun], schemes: Sequence[str]) -> Report:
    """Table rows (lowest seed of each checkpoint, plus constant velocity and AVG) with
    intervals, paired differences and seed spreads."""
    primary = primary_runs(runs)
    rows = with_split_means([row for run in primary.values() for row in run.rows])
    columns = list(dict.fromkeys(_column(r) for r in rows))
    return Report(
        rows=with_intervals(rows, primary),
        paired=paired_differences(primary, columns),
        seeds=seed_spreads(runs, columns),
        to_best=differences_to_best(primary, rows, columns),
        density=density_rows(list(primary.values())),
        ablations=ablation_rows(list(primary.values())),
    )
