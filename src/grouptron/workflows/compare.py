"""Two models (checkpoints or forecast files made anywhere) scored on the same benchmark test
samples, and the paired difference B - A with its 95% interval over resampled time steps.

    from grouptron.workflows.compare import compare
    rows = compare("trajectron++-eth-central", "grouptron-eth-central")
    print(rows[0].fde)  # Interval(mean=..., low=..., high=...): B - A, metres
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from grouptron.config import DataConfig
from grouptron.constants import SPLITS
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import SampleScores, score_samples
from grouptron.evaluation.test_sets import load_test_set
from grouptron.evaluation.uncertainty import Interval, mean_interval, split_average_interval
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import uses_groups
from grouptron.model.predict import default_point_forecast
from grouptron.point_forecast import is_evaluation_mode
from grouptron.workflows.evaluate_files import (
    ForecastFiles,
    read_forecasts,
    scored_forecast_files,
)
from grouptron.workflows.held_out import seen_splits

Side = str | Path | ForecastFiles
"""A checkpoint (a shipped name, a file or a run folder) or forecast files."""
SPLIT_MEAN = "mean"
"""The row of the unweighted mean over the splits compared (with more than one)."""


@dataclass(frozen=True)
class Compared:
    """A and B on one split's test samples (or their mean over the splits).

    Attributes:
        split: the split, or :data:`SPLIT_MEAN`.
        samples: test samples, the same for both (summed over the splits for the mean).
        modes: (A's, B's) evaluation mode.
        a, b: (ADE, FDE) in metres.
        ade, fde: B - A with its 95% interval over resampled time steps; below zero: B is
            closer to the truth.
        others: every other metric registered while comparing (``--metrics``; each lower is
            better): name -> (A's mean, B's mean, B - A with its interval).
    """

    split: str
    samples: int
    modes: tuple[str, str]
    a: tuple[float, float]
    b: tuple[float, float]
    ade: Interval
    fde: Interval
    others: dict[str, tuple[float, float, Interval]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: the differences as ``{mean, low, high}``."""
        return {
            "split": self.split,
            "samples": self.samples,
            "modes": list(self.modes),
            "a": {"ade": self.a[0], "fde": self.a[1]},
            "b": {"ade": self.b[0], "fde": self.b[1]},
            "difference": {
                name: {"mean": d.mean, "low": d.low, "high": d.high}
                for name, d in (("ade", self.ade), ("fde", self.fde))
            },
            "metrics": {
                name: {"a": a, "b": b, "difference": {"mean": d.mean, "low": d.low, "high": d.high}}
                for name, (a, b, d) in self.others.items()
            },
        }


@dataclass(frozen=True)
class _Scored:
    name: str
    split: str
    samples: SampleSet
    scores: SampleScores


def _score(side: Side, split: str, mode: str | None, data_dir: Path, seed: int) -> _Scored:
    """One side's per-sample scores on ``split``'s test set."""
    if isinstance(side, ForecastFiles):
        read = read_forecasts(side)
        chosen = mode or read.default_modes()[0]
        data = DataConfig()
        samples, _ = load_test_set(data_dir, split, data)
        recordings = split_files(data_dir, split, "test")
        samples, scored = scored_forecast_files(read, recordings, samples, (chosen,), data)
        return _Scored(side.name, split, samples, scored[0][2])
    model, experiment = load_trained_model(resolve_checkpoint(side))
    seen_splits(experiment, str(side), data_dir, (split,), include_seen=False)
    grouped = experiment.groups if uses_groups(experiment) else None
    samples, groups = load_test_set(data_dir, split, experiment.data, group_config=grouped)
    chosen = mode or default_point_forecast(experiment).name
    (scores,) = score_samples(model, experiment, samples, (chosen,), groups=groups, seed=seed)
    return _Scored(str(side), split, samples, scores)


def _own_split(side: Side) -> str | None:
    """A checkpoint's benchmark split (None for forecast files or another dataset's model)."""
    if isinstance(side, ForecastFiles):
        return None
    _, experiment = load_trained_model(resolve_checkpoint(side))
    return experiment.split if experiment.split in SPLITS and not experiment.dataset else None


def _splits(a: Side, b: Side, splits: tuple[str, ...] | None) -> tuple[str, ...]:
    """The splits asked, else the checkpoints' own one (they must agree)."""
    if splits:
        unknown = [s for s in splits if s not in SPLITS]
        if unknown:
            raise GrouptronError(f"unknown split {unknown[0]!r}; choose from {', '.join(SPLITS)}")
        return splits
    own = {s for s in (_own_split(a), _own_split(b)) if s is not None}
    if len(own) != 1:
        why = "are of different splits" if own else "name no benchmark split"
        raise GrouptronError(f"A and B {why}: give the split to compare them on (--split)")
    return (own.pop(),)


def _paired(a: _Scored, b: _Scored) -> Compared:
    """One split's paired difference, refused where the two were not scored on one set."""
    same = len(a.samples) == len(b.samples) and all(
        np.array_equal(getattr(a.samples, k), getattr(b.samples, k))
        for k in ("scene_index", "track", "step")
    )
    if not same:
        raise GrouptronError(
            f"{a.name} and {b.name} were not scored on the same {a.split} test samples "
            "(forecast files that lack some cannot be compared)"
        )
    steps = time_step_ids(a.samples)
    return Compared(
        a.split,
        len(a.samples),
        (a.scores.mode, b.scores.mode),
        (float(np.mean(a.scores.ade)), float(np.mean(a.scores.fde))),
        (float(np.mean(b.scores.ade)), float(np.mean(b.scores.fde))),
        mean_interval(b.scores.ade - a.scores.ade, steps),
        mean_interval(b.scores.fde - a.scores.fde, steps),
        {
            name: (
                float(np.mean(a.scores.get(name))),
                float(np.mean(b.scores.get(name))),
                mean_interval(b.scores.get(name) - a.scores.get(name), steps),
            )
            for name in _other_metrics(a.scores)
        },
    )


def _other_metrics(scores: SampleScores) -> list[str]:
    """The metrics scored beside ADE and FDE (those ``--metrics`` added)."""
    return [
        name for name in metrics.METRICS if name not in ("ade", "fde") and name in scores.values
    ]


def compare(
    a: Side,
    b: Side,
    splits: tuple[str, ...] | None = None,
    mode: str | None = None,
    *,
    data_dir: str | Path | None = None,
    seed: int = 0,
) -> list[Compared]:
    """A and B on the test samples of each split (default: the checkpoints' own), each in
    ``mode`` (default: its own point forecast; a file's: ``ml``, or best-of-K of its samples),
    and with several splits the mean over them; a checkpoint is refused on a split it trained
    on."""
    if mode is not None and not is_evaluation_mode(mode):
        raise GrouptronError(f"unknown mode {mode!r}; choose ml, ml-argmax, mean, best-of-K ...")
    chosen = _splits(a, b, splits)
    root = resolve_data_dir(data_dir)
    rows = []
    for split in chosen:
        with torch.inference_mode():
            pair = [_score(side, split, mode, root, seed) for side in (a, b)]
        rows.append((_paired(*pair), pair))
    compared = [row for row, _ in rows]
    if len(chosen) > 1:
        compared.append(_split_mean(rows))
    return compared


def _split_mean(rows: list[tuple[Compared, list[_Scored]]]) -> Compared:
    """The unweighted mean over the splits (the papers' AVG), intervals resampling each split's
    time steps on their own."""
    differences = {
        metric: [
            (b.scores.get(metric) - a.scores.get(metric), time_step_ids(a.samples))
            for _, (a, b) in rows
        ]
        for metric in ("ade", "fde", *rows[0][0].others)
    }
    first = rows[0][0]
    others = {
        name: (
            float(np.mean([r.others[name][0] for r, _ in rows])),
            float(np.mean([r.others[name][1] for r, _ in rows])),
            split_average_interval(differences[name]),
        )
        for name in first.others
    }
    return Compared(
        SPLIT_MEAN,
        sum(row.samples for row, _ in rows),
        first.modes,
        (float(np.mean([r.a[0] for r, _ in rows])), float(np.mean([r.a[1] for r, _ in rows]))),
        (float(np.mean([r.b[0] for r, _ in rows])), float(np.mean([r.b[1] for r, _ in rows]))),
        split_average_interval(differences["ade"]),
        split_average_interval(differences["fde"]),
        others,
    )


def compared_table(rows: list[Compared], names: tuple[str, str]) -> str:
    """A table: per split, A's and B's ADE/FDE and B - A with its interval."""
    lines = [
        f"A: {names[0]}",
        f"B: {names[1]}",
        f"{'split':<7} {'samples':>7} {'A ADE/FDE m':>14} {'B ADE/FDE m':>14}   "
        "B - A ADE m (95% interval)   B - A FDE m (95% interval)",
    ]
    for row in rows:
        a, b = (f"{v[0]:.3f}/{v[1]:.3f}" for v in (row.a, row.b))
        ade, fde = (f"{d.mean:+.3f} [{d.low:+.3f}, {d.high:+.3f}]" for d in (row.ade, row.fde))
        lines.append(f"{row.split:<7} {row.samples:>7} {a:>14} {b:>14}   {ade:<28} {fde}")
    for name in rows[0].others if rows else ():
        lines.append(f"{metrics.metric_label(name)}:")
        for row in rows:
            a_mean, b_mean, d = row.others[name]
            difference = f"{d.mean:+.4f} [{d.low:+.4f}, {d.high:+.4f}]"
            lines.append(f"  {row.split:<7} A {a_mean:.4f}  B {b_mean:.4f}  B - A {difference}")
    modes = rows[0].modes if rows else ("", "")
    lines.append(f"modes: A {modes[0]}, B {modes[1]}; below zero: B is closer to the truth")
    return "\n".join(lines)
