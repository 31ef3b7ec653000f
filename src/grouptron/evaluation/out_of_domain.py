"""Out-of-domain scores: causal checkpoints against constant velocity on the test parts of
datasets of one's own (:mod:`grouptron.data.custom` descriptions: recordings from elsewhere in
their own formats). Every model is compared with constant velocity on its own samples, so every
difference is paired.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.data.custom import DatasetDescription
from grouptron.data.samples import SampleSet, concatenate_samples
from grouptron.data.subsets import density_masks, time_step_ids
from grouptron.evaluation.evaluate import (
    SampleScores,
    constant_velocity_scores,
    score_samples,
)
from grouptron.evaluation.recordings import recording_samples
from grouptron.evaluation.scored import CONSTANT_VELOCITY
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.groups.assign import assign_groups
from grouptron.model.checkpoint import BEST_WEIGHTS_FILE, load_checkpoint, load_trained_model
from grouptron.model.factory import uses_groups

POOLED_BIN = "all"
MIN_BIN_SAMPLES = 20
"""Density bins with fewer samples than this are left out of the pooled table."""
TEST_PART = "test"


@dataclass(frozen=True)
class RecordingRow:
    """One model (or constant velocity) on one recording's samples; FDEs in metres."""

    recording: str
    model: str
    mode: str | None
    """The point forecast (``ml``, ``ml-argmax``, ``mean``); None for constant velocity."""
    samples: int
    ade: float
    fde: Interval
    fde_constant_velocity: float
    difference: Interval
    """Model minus constant velocity FDE on the same samples (zero for the baseline)."""

    @property
    def ratio(self) -> float:
        """FDE over constant velocity's."""
        return self.fde.mean / self.fde_constant_velocity

    def to_dict(self) -> dict[str, object]:
        return {**dataclasses.asdict(self), "fde_over_constant_velocity": self.ratio}


@dataclass(frozen=True)
class PooledRow:
    """One model on every recording pooled, in one density bin (``all``: every sample)."""

    model: str
    mode: str | None
    bin: str
    samples: int
    fde: float
    fde_constant_velocity: float
    difference: Interval

    @property
    def ratio(self) -> float:
        return self.fde / self.fde_constant_velocity

    def to_dict(self) -> dict[str, object]:
        return {**dataclasses.asdict(self), "fde_over_constant_velocity": self.ratio}


@dataclass(frozen=True)
class OutOfDomain:
    """Everything the out-of-domain section shows."""

    datasets: tuple[DatasetDescription, ...]
    recordings: list[RecordingRow]
    pooled: list[PooledRow]
    default_model: str | None = None
    """The checkpoint folder whose targets the section checks (the library's default model)."""

    def to_dict(self) -> dict[str, object]:
        return {
            "recordings": [r.to_dict() for r in self.recordings],
            "pooled": [p.to_dict() for p in self.pooled],
        }


def causal_checkpoints(root: Path) -> list[Path]:
    """Every ``*/best.safetensors`` under ``root`` that forecasts from causal inputs (backward
    derivatives, neighbours at the forecast step only), in folder-name order."""
    found = []
    for path in sorted(Path(root).glob(f"*/{BEST_WEIGHTS_FILE}")):
        data = load_checkpoint(path).config.data
        if data.derivatives == "backward" and tuple(data.neighbour_window_steps) == (0, 0):
            found.append(path)
    return found


def _samples(datasets: Sequence[DatasetDescription], data: DataConfig) -> SampleSet:
    """Every test file's samples in one set, one scene per file (ids unique across datasets)."""
    parts = [recording_samples(d.files(TEST_PART), d.recording, data) for d in datasets]
    return concatenate_samples(parts)


def score_out_of_domain(
    datasets: Sequence[DatasetDescription],
    checkpoints: Sequence[Path],
    modes: Sequence[str] = ("ml",),
    default_model: str | None = None,
    progress: bool = False,
) -> OutOfDomain:
    """Constant velocity and every checkpoint (rows named by its folder) in each point-forecast
    ``mode`` on every test file of ``datasets``: per-recording rows and pooled rows by density
    bin, 95% intervals over resampled time steps; ``default_model`` names the folder whose
    targets are checked."""
    names = [f.name for d in datasets for f in d.files(TEST_PART)]
    samples = _samples(datasets, DataConfig(derivatives="backward"))
    recordings, pooled = _rows(CONSTANT_VELOCITY, None, samples, None, names)
    for path in checkpoints:
        model, config = load_trained_model(path)
        samples = _samples(datasets, config.data)
        groups = (
            assign_groups(samples, config.groups, config.data.position_scale_m)
            if uses_groups(config)
            else None
        )
        per_mode = score_samples(
            model, config, samples, tuple(modes), groups=groups, progress=progress
        )
        for scores in per_mode:
            rows = _rows(path.parent.name, scores.mode, samples, scores, names)
            recordings += rows[0]
            pooled += rows[1]
    recordings.sort(key=lambda r: names.index(r.recording))  # stable: models stay in order
    return OutOfDomain(tuple(datasets), recordings, pooled, default_model)


def _rows(
    label: str,
    mode: str | None,
    samples: SampleSet,
    scores: SampleScores | None,
    names: Sequence[str],
) -> tuple[list[RecordingRow], list[PooledRow]]:
    """One model's rows in one mode (constant velocity's with ``scores`` None): per recording
    (scene ``i`` of ``samples`` is recording ``names[i]``) and pooled per density bin."""
    cv = constant_velocity_scores(samples, DataConfig().horizon_steps)
    ade, fde = (cv.ade, cv.fde) if scores is None else (scores.ade, scores.fde)
    steps = time_step_ids(samples)
    recordings = [
        RecordingRow(
            name,
            label,
            mode,
            int(keep.sum()),
            float(ade[keep].mean()),
            mean_interval(fde[keep], steps[keep]),
            float(cv.fde[keep].mean()),
            mean_interval(fde[keep] - cv.fde[keep], steps[keep]),
        )
        for i, name in enumerate(names)
        if (keep := samples.scene_index == i).any()
    ]
    bins = {POOLED_BIN: np.ones(len(samples), dtype=bool), **density_masks(samples)}
    pooled = [
        PooledRow(
            label,
            mode,
            bin_name,
            int(keep.sum()),
            float(fde[keep].mean()),
            float(cv.fde[keep].mean()),
            mean_interval(fde[keep] - cv.fde[keep], steps[keep]),
        )
        for bin_name, keep in bins.items()
        if keep.sum() >= MIN_BIN_SAMPLES
    ]
    return recordings, pooled


def _signed(value: Interval) -> str:
    return f"{value.mean:+.3f} [{value.low:+.3f}, {value.high:+.3f}]"


def default_model_checks(result: OutOfDomain) -> list[str]:
    """The target lines for the default model in each mode scored (none when it was not
    scored): at or below constant velocity's FDE on every recording, and FDE over constant
    velocity's not growing with density (the densest bin's ratio at or below the pooled one)."""
    name = result.default_model
    lines = []
    for mode in dict.fromkeys(r.mode for r in result.recordings if r.model == name):
        rows = [r for r in result.recordings if (r.model, r.mode) == (name, mode)]
        bins = [p for p in result.pooled if (p.model, p.mode) == (name, mode)]
        worst = max(rows, key=lambda r: r.ratio)
        pooled, densest = bins[0], bins[-1]
        lines += [
            f"- Default model `{name}` ({mode}) at or below constant velocity's FDE on every "
            f"recording: {_verdict(all(r.ratio <= 1.0 for r in rows))} (highest FDE / CV "
            f"{worst.ratio:.3f}, {worst.recording})",
            f"- `{name}` ({mode}) FDE / CV not growing with density: "
            f"{_verdict(densest.ratio <= pooled.ratio)} ({densest.bin} {densest.ratio:.3f}, "
            f"all {pooled.ratio:.3f})",
        ]
    return lines


def _verdict(ok: bool) -> str:
    return "met" if ok else "NOT met"


def _label(model: str, mode: str | None) -> str:
    return model if mode is None else f"{model} ({mode})"


def out_of_domain_markdown(result: OutOfDomain | None) -> list[str]:
    """The report section (none without a result): the sets read, the per-recording table (of
    the default model when it was scored, else of every model), the pooled table by density of
    every model and the default model's targets."""
    if result is None:
        return []
    out = [
        "",
        "## Out of domain",
        "",
        "Causal checkpoints (named by folder; in brackets the point forecast: `ml` the",
        "benchmark's most likely, `ml-argmax` the most probable latent value's, `mean` the",
        "p(z|x)-weighted mean) and constant velocity on recordings from elsewhere, resampled to",
        "0.4 s; every person with 8 observed and 12 future points. FDE in metres with its 95%",
        "interval over resampled time steps; the difference to constant velocity is paired on",
        "the same samples (`*`: the interval excludes zero).",
        "",
    ]
    for d in result.datasets:
        fmt = d.recording
        out.append(
            f"- {d.name}: {', '.join(f.name for f in d.files(TEST_PART))} (columns "
            f"{','.join(fmt.columns)}, {fmt.fps if fmt.fps is not None else 'ETH/UCY'} fps, "
            f"{fmt.units})"
        )
    shown = {CONSTANT_VELOCITY, result.default_model}
    rows = [r for r in result.recordings if r.model in shown]
    if len({r.model for r in rows}) < 2:  # the default model was not scored: show them all
        rows = result.recordings
    out += ["", "| recording | model | samples | ADE m | FDE m | FDE - CV m | FDE / CV |"]
    out += ["|---|---|---|---|---|---|---|"]
    for r in rows:
        star = "*" if r.difference.low > 0 or r.difference.high < 0 else ""
        out.append(
            f"| {r.recording} | {_label(r.model, r.mode)} | {r.samples} | {r.ade:.3f} | "
            f"{r.fde.mean:.3f} [{r.fde.low:.3f}, {r.fde.high:.3f}] | "
            f"{_signed(r.difference)}{star} | {r.ratio:.3f} |"
        )
    bins = list(dict.fromkeys(p.bin for p in result.pooled))
    out += ["", "FDE over constant velocity's, every recording pooled, by neighbours within 3 m"]
    out += ["(in brackets: samples):", ""]
    out += ["| model | " + " | ".join(bins) + " |", "|---|" + "---|" * len(bins)]
    for model, mode in dict.fromkeys((p.model, p.mode) for p in result.pooled):
        cells = {
            p.bin: f"{p.ratio:.3f} ({p.samples})"
            for p in result.pooled
            if (p.model, p.mode) == (model, mode)
        }
        label = _label(model, mode)
        out.append(f"| {label} | " + " | ".join(cells.get(b, "-") for b in bins) + " |")
    checks = default_model_checks(result)
    return out + (["", *checks] if checks else [])
