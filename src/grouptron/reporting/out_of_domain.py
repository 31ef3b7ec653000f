"""Out-of-domain scores: causal checkpoints against constant velocity on the test parts of
datasets of one's own (:mod:`grouptron.data.datasets.custom` descriptions: recordings from
elsewhere in their own formats). Every model is compared with constant velocity on its own
samples, so every difference is paired.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.custom import DatasetDescription
from grouptron.data.datasets.subsets import density_masks, time_step_ids
from grouptron.data.formats.track_files import TrackSource
from grouptron.data.prepare.samples import SampleSet, concatenate_samples
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores
from grouptron.evaluation.recordings import recording_samples, training_files
from grouptron.evaluation.score_cache import cached_score_samples
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.model.checkpoint import load_checkpoint, load_trained_model, stored_checkpoints
from grouptron.model.factory import groups_for_model
from grouptron.point_forecast import NAMED as POINT_FORECASTS
from grouptron.point_forecast import is_point_forecast

POOLED_BIN = "all"
MIN_BIN_SAMPLES = 20
"""Density bins with fewer samples than this are left out of the pooled table (``all`` never)."""
TEST_PART = "test"
BASELINE_DATA = DataConfig(derivatives="backward")


@dataclass(frozen=True)
class OutOfDomainSet:
    """The recordings to score, read and checked before any model runs.

    Attributes:
        datasets: the descriptions whose test parts are scored.
        names: (F,) every test file's name, unique; scene ``i`` of a sample set is ``names[i]``.
        baseline: constant velocity's samples (every person with a full history and future).
    """

    datasets: tuple[DatasetDescription, ...]
    names: tuple[str, ...]
    baseline: SampleSet


@dataclass(frozen=True)
class RecordingRow:
    """One model (or constant velocity) on one recording's samples; FDEs in metres."""

    recording: str
    model: str
    mode: str | None
    """The point forecast (``ml``, ``ml-argmax``, ``mean``, ``ml-top10``, ``ml-topK``); None for
    constant velocity."""
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
        """The row as a dict (intervals as ``{mean, low, high}``) plus
        ``fde_over_constant_velocity``."""
        return {**asdict(self), "fde_over_constant_velocity": self.ratio}


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
        """FDE over constant velocity's."""
        return self.fde / self.fde_constant_velocity

    def to_dict(self) -> dict[str, object]:
        """The row as a dict (the interval as ``{mean, low, high}``) plus
        ``fde_over_constant_velocity``."""
        return {**asdict(self), "fde_over_constant_velocity": self.ratio}


@dataclass(frozen=True)
class OutOfDomain:
    """Everything the out-of-domain section shows."""

    recordings_read: OutOfDomainSet
    checkpoints: tuple[str, ...]
    recordings: tuple[RecordingRow, ...]
    pooled: tuple[PooledRow, ...]
    default_model: str | None = None
    """The checkpoint folder whose targets the section checks (the library's default model)."""

    def to_dict(self) -> dict[str, object]:
        """The section as a dict for the report's JSON: the datasets and their test files, the
        checkpoints, the default model's target checks and every row."""
        return {
            "datasets": [
                {
                    "name": d.name,
                    "source": str(d.source),
                    "files": [str(f) for f in d.files("test")],
                }
                for d in self.recordings_read.datasets
            ],
            "checkpoints": list(self.checkpoints),
            "default_model": self.default_model,
            "targets": default_model_checks(self),
            "recordings": [r.to_dict() for r in self.recordings],
            "pooled": [p.to_dict() for p in self.pooled],
        }


def prepare_out_of_domain(datasets: Sequence[DatasetDescription]) -> OutOfDomainSet:
    """Read every test file once and check what can fail (a missing test part, two files of
    one name, nobody with a full history and future), before the long work."""
    files = [f for d in datasets for f in d.files(TEST_PART)]
    doubled = sorted(name for name, n in Counter(f.name for f in files).items() if n > 1)
    if doubled:
        raise GrouptronError(f"out-of-domain recordings need distinct file names: {doubled}")
    return OutOfDomainSet(tuple(datasets), tuple(f.name for f in files), _samples(datasets))


def causal_checkpoints(root: Path) -> list[Path]:
    """Every ``*/best.safetensors`` under ``root`` that forecasts from causal inputs
    (:attr:`DataConfig.causal`) with neighbours taken at t alone (so that its density bins
    count the same people as constant velocity's), in folder-name order."""
    return [
        path
        for path, config in stored_checkpoints(root)
        if config.data.causal and tuple(config.data.neighbour_window_steps) == (0, 0)
    ]


def _samples(datasets: Sequence[DatasetDescription], data: DataConfig = BASELINE_DATA) -> SampleSet:
    """Every test file's samples in one set, one scene per file (ids unique across datasets)."""
    parts = [
        recording_samples(
            [TrackSource.from_format(f, d.recording) for f in d.files(TEST_PART)], data
        )
        for d in datasets
    ]
    return concatenate_samples(parts)


def score_out_of_domain(
    recordings: OutOfDomainSet,
    checkpoints: Sequence[Path],
    modes: Sequence[str] = ("ml",),
    *,
    default_model: str | None = None,
    progress: bool = False,
    score_cache: Path | None = None,
) -> OutOfDomain:
    """Constant velocity and every checkpoint (rows named by its folder) in each point-forecast
    ``mode`` on every prepared recording: per-recording rows and pooled rows by density bin,
    95% intervals over resampled time steps; ``default_model`` names the folder whose targets
    are checked; ``score_cache`` keeps per-sample scores between runs (None: not kept)."""
    unknown = [m for m in modes if not is_point_forecast(m)]
    if unknown or not modes:
        raise GrouptronError(
            f"out-of-domain scores need point forecasts ({', '.join(POINT_FORECASTS)}, "
            "ml-topK), "
            f"not {', '.join(unknown) or 'none'}"
        )
    labels = [path.parent.name for path in checkpoints]
    doubled = sorted(label for label, n in Counter(labels).items() if n > 1)
    if doubled:  # rows are named by folder: two of one name would merge
        raise GrouptronError(f"out-of-domain checkpoints need distinct folder names: {doubled}")
    _refuse_seen(recordings, checkpoints)
    names = recordings.names
    rows, pooled = _rows(CONSTANT_VELOCITY, None, recordings.baseline, BASELINE_DATA, None, names)
    for path in checkpoints:
        model, config = load_trained_model(path)
        samples = _samples(recordings.datasets, config.data)
        groups = groups_for_model(samples, config)
        scored = cached_score_samples(
            score_cache, model, config, samples, modes, groups=groups, progress=progress
        )
        for scores in scored:
            per_recording, per_bin = _rows(
                path.parent.name, scores.mode, samples, config.data, scores, names
            )
            rows += per_recording
            pooled += per_bin
    rows.sort(key=lambda r: names.index(r.recording))  # stable: models stay in order
    return OutOfDomain(recordings, tuple(labels), tuple(rows), tuple(pooled), default_model)


def _refuse_seen(recordings: OutOfDomainSet, checkpoints: Sequence[Path]) -> None:
    """Refuse, before the long work, a checkpoint that trained or validated on one of the
    recordings (byte for byte): its scores there would not be out of domain."""
    files = [f for d in recordings.datasets for f in d.files(TEST_PART)]
    for path in checkpoints:
        seen = training_files(files, load_checkpoint(path).config)
        if seen:
            raise GrouptronError(
                f"{path.parent.name} trained or validated on {Path(seen[0]).name}, so its scores "
                "there are not held out: leave it out of the checkpoints or that recording out "
                "of --out-of-domain"
            )


def _rows(
    label: str,
    mode: str | None,
    samples: SampleSet,
    data: DataConfig,
    scores: SampleScores | None,
    names: Sequence[str],
) -> tuple[list[RecordingRow], list[PooledRow]]:
    """One model's rows in one mode (constant velocity's with ``scores`` None): per recording
    (scene ``i`` of ``samples`` is recording ``names[i]``) and pooled per density bin."""
    cv = constant_velocity_scores(samples, data.horizon_steps)
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
        if bin_name == POOLED_BIN or keep.sum() >= MIN_BIN_SAMPLES
    ]
    return recordings, pooled


def default_model_checks(result: OutOfDomain) -> list[str]:
    """The default model's target lines in each mode scored (none when it was not scored): at
    or below constant velocity's FDE on every recording, and FDE over constant velocity's not
    growing with density (the densest bin's ratio at or below that of all samples)."""
    name = result.default_model
    densest = list(density_masks(result.recordings_read.baseline))[-1]
    lines = []
    for mode in dict.fromkeys(r.mode for r in result.recordings if r.model == name):
        rows = [r for r in result.recordings if (r.model, r.mode) == (name, mode)]
        bins = {p.bin: p for p in result.pooled if (p.model, p.mode) == (name, mode)}
        worst = max(rows, key=lambda r: r.ratio)
        lines.append(
            f"- Default model `{name}` ({mode}) at or below constant velocity's FDE on every "
            f"recording: {_verdict(all(r.ratio <= 1.0 for r in rows))} (highest FDE / CV "
            f"{worst.ratio:.3f}, {worst.recording})"
        )
        whole, dense = bins[POOLED_BIN], bins.get(densest)
        verdict = (
            f"{_verdict(dense.ratio <= whole.ratio)} ({densest} {dense.ratio:.3f}, "
            f"all {whole.ratio:.3f})"
            if dense
            else f"not judged (fewer than {MIN_BIN_SAMPLES} samples with {densest})"
        )
        lines.append(f"- `{name}` ({mode}) FDE / CV not growing with density: {verdict}")
    return lines


def _verdict(ok: bool) -> str:
    return "met" if ok else "NOT met"


def _label(model: str, mode: str | None) -> str:
    return model if mode is None else f"{model} ({mode})"


def _notes(result: OutOfDomain) -> list[str]:
    """What the section could not show, said rather than left out."""
    if not result.checkpoints:
        return ["", "No causal checkpoint was found: constant velocity only."]
    if result.default_model and result.default_model not in result.checkpoints:
        return ["", f"The default model `{result.default_model}` was not among the checkpoints."]
    return []


# One Markdown section: the header text, three tables and the target lines, in order.
def out_of_domain_markdown(result: OutOfDomain | None) -> list[str]:
    """The report section (none without a result): the recordings read (with their samples),
    the per-recording table (of the default model when it was scored, else of every model),
    the pooled table by density of every model and the default model's targets."""
    if result is None:
        return []
    data = BASELINE_DATA
    out = [
        "",
        "## Out of domain",
        "",
        "Causal checkpoints (named by folder; in brackets the point forecast: `ml` the",
        "benchmark's most likely, `ml-argmax` the most probable latent value's, `mean` the",
        "p(z|x)-weighted mean, `ml-top10` (`ml-topK`) the most likely of the 10 (K) most",
        "probable latent values)",
        "and constant velocity on recordings from elsewhere, resampled to",
        f"{data.dt_s} s; every person with {data.history_steps} observed and "
        f"{data.horizon_steps} future points (in brackets",
        "after each file). FDE in metres with its 95% interval over resampled time steps; the",
        "difference to constant velocity is paired on the same samples (`*`: the interval",
        "excludes zero).",
        "",
    ]
    counts = np.bincount(result.recordings_read.baseline.scene_index, minlength=0)
    count = dict(zip(result.recordings_read.names, counts.tolist(), strict=False))
    for d in result.recordings_read.datasets:
        fmt = d.recording
        files = ", ".join(f"{f.name} ({count.get(f.name, 0)})" for f in d.files(TEST_PART))
        fps = fmt.fps if fmt.fps is not None else "ETH/UCY"
        out.append(f"- {d.name}: {files}; columns {','.join(fmt.columns)}, {fps} fps, {fmt.units}")
    shown = {CONSTANT_VELOCITY, result.default_model}
    rows = [r for r in result.recordings if r.model in shown]
    if len({r.model for r in rows}) < 2:  # the default model was not scored: show them all
        rows = list(result.recordings)
    out += ["", "| recording | model | samples | ADE m | FDE m | FDE - CV m | FDE / CV |"]
    out += ["|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(
            f"| {r.recording} | {_label(r.model, r.mode)} | {r.samples} | {r.ade:.3f} | "
            f"{r.fde.mean:.3f} [{r.fde.low:.3f}, {r.fde.high:.3f}] | "
            f"{r.difference.signed_text()} | {r.ratio:.3f} |"
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
    return out + _notes(result) + (["", *checks] if checks else [])
