"""Forecast files made by any code scored as ``evaluate`` scores a checkpoint: on the
benchmark's own test samples, each found by its recording's frame number and person id.

    from grouptron.workflows.evaluate import Benchmark, evaluate
    from grouptron.workflows.evaluate_files import ForecastFiles
    rows = evaluate(Benchmark(splits=("eth",)), ForecastFiles(("eth.csv",)), ("ml",))
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.dataset import load_scenes
from grouptron.data.formats.forecast_file import ForecastRows, read_forecast_file
from grouptron.data.formats.time_base import TimeBase
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import SampleSet
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores
from grouptron.evaluation.forecast_scores import file_scores, positions_of_samples, sample_keys
from grouptron.evaluation.recordings import recording_rows, recording_samples
from grouptron.evaluation.results import EvaluationResult

Scored = list[tuple[str, str | None, SampleScores]]
"""(model name, what it was loaded from, scores) per row, as evaluate's rows are made."""


@dataclass(frozen=True)
class ForecastFiles:
    """Forecast files (CSV layout 2 with an optional ``sample`` column, or TrajNet++
    ``.ndjson``), one per test recording, each named after its recording where a split has
    several (``students001.csv``, ``students003-mine.csv``).

    Attributes:
        files: the files.
        name: the model's name in the rows (default: the first file's name without suffix).
        allow_missing: score the samples the files have (their count said) instead of
            refusing files that lack some.
    """

    files: tuple[Path, ...]
    name: str = ""
    allow_missing: bool = False

    def __post_init__(self) -> None:
        files = (self.files,) if isinstance(self.files, str | Path) else tuple(self.files)
        if not files:
            raise GrouptronError("ForecastFiles needs at least one file")
        object.__setattr__(self, "files", tuple(Path(f) for f in files))
        object.__setattr__(self, "name", self.name or self.files[0].stem)

    @property
    def label(self) -> str:
        """The files, as a row's source."""
        return ", ".join(str(f) for f in self.files)


@dataclass(frozen=True)
class ReadForecasts:
    """Forecast files with their rows, read once; ``single_split``: one split is scored, so
    one file of a split with one test recording needs no name."""

    files: ForecastFiles
    rows: tuple[ForecastRows, ...]
    single_split: bool = True

    def default_modes(self) -> tuple[str, ...]:
        """``ml`` for point forecasts, else best-of-20 (of all, if fewer are given)."""
        counts = {1 if r.sample is None else len(np.unique(r.sample)) for r in self.rows}
        fewest = min(counts)
        return ("ml",) if fewest == 1 else (f"best-of-{min(fewest, 20)}",)


def refuse_for_files(on_benchmark: bool, takes_away: bool, modes: Sequence[str] | None) -> None:
    """Refuse for forecast files what needs other samples (no split named, a dataset:
    ``on_benchmark`` False) or a model (``takes_away``: ablations or regions; the NLL)."""
    if not on_benchmark:
        raise GrouptronError(
            "forecast files are scored on the test sets of the benchmark splits they forecast "
            "(name them with --split) or on the recordings they forecast (--tracks)"
        )
    if takes_away or "nll" in (modes or ()):
        raise GrouptronError(
            "forecast files hold positions only: --ablate, --regions and --mode nll need a "
            "--checkpoint"
        )


def read_forecasts(files: ForecastFiles) -> ReadForecasts:
    """Every file's rows (a sample column of only sample 0, as a point forecast's
    ``.ndjson`` has, is a point forecast)."""
    rows = []
    for path in files.files:
        read = read_forecast_file(path)
        if read.sample is not None and (read.sample == read.sample[0]).all():
            read = ForecastRows(read.frame, read.ids, read.step, read.xy_m, None)
        rows.append(read)
    return ReadForecasts(files, tuple(rows))


def _file_of(
    read: ReadForecasts, recording: Path, recordings: list[Path]
) -> tuple[ForecastRows, str]:
    """The rows of the file for ``recording`` and its name: the one named after it, or the
    only one where one split of one test recording (or one recording) is scored."""
    for path, rows in zip(read.files.files, read.rows, strict=True):
        if path.stem.startswith(recording.stem):
            return rows, str(path)
    if len(read.files.files) == 1 and len(recordings) == 1 and read.single_split:
        return read.rows[0], str(read.files.files[0])
    names = ", ".join(f"{r.stem}{read.files.files[0].suffix}" for r in recordings)
    raise GrouptronError(
        f"no forecast file named after the test recording {recording.name}: give one file per "
        f"recording, named after it ({names})"
    )


def recording_scenes(
    sources: Sequence[TrackSource], data: DataConfig
) -> tuple[list[Scene], list[TimeBase]]:
    """The scene of every recording, as ``evaluation.recordings`` builds it, and its time
    base (which turns its frames into the file's own, as ``predict`` writes them)."""
    scenes, times = [], []
    for source in sources:
        source = dataclasses.replace(source, on_gap=data.on_gap)
        table, _ = read_track_file(source, data.frames_per_step, data.dt_s)
        scenes.append(build_scene(table, data, name=Path(source.path).name))
        times.append(table.times)
    return scenes, times


def scored_forecast_files(
    read: ReadForecasts,
    recordings: list[Path],
    samples: SampleSet,
    modes: tuple[str, ...],
    data: DataConfig,
    scenes: tuple[list[Scene], list[TimeBase]] | None = None,
) -> tuple[SampleSet, Scored]:
    """The samples scored (all, or with ``allow_missing`` those the files have) and the rows'
    scores: the files' in each mode, then constant velocity's on the same samples. ``scenes``:
    the recordings' scenes and time bases (:func:`recording_scenes`; None: benchmark files)."""
    built, times = scenes if scenes is not None else (load_scenes(recordings, data), None)
    frames, ids = sample_keys(built, samples)
    if times is not None:  # the file's own frame numbers, as predict writes them
        for index, time_base in enumerate(times):
            mine = samples.scene_index == index
            own = time_base.file_frames(frames[mine])
            frames[mine] = frames[mine] if own is None else own
    scenes_list = built
    H = data.horizon_steps
    parts = []
    for path in recordings:  # one file per test recording
        rows, name = _file_of(read, path, recordings)
        parts.append(positions_of_samples(rows, frames, ids, H, name))
    counts = {p.shape[1] for p, _ in parts}
    if len(counts) > 1:
        raise GrouptronError(f"{read.files.label}: the files hold different numbers of samples")
    positions = np.full_like(parts[0][0], np.nan)
    found = np.zeros(len(samples), bool)
    for index, (own, has) in enumerate(parts):
        mine = samples.scene_index == index
        positions[mine], found[mine] = own[mine], has[mine]
    centres = np.array([scene.centre_world_m for scene in scenes_list])  # (scenes, 2)
    now_m = samples.pos_now_scene_m + centres[samples.scene_index]  # (S, 2) the files' frame
    missing = int((~found).sum())
    if missing and not read.files.allow_missing:
        raise GrouptronError(
            f"{read.files.label}: {missing} of the {len(samples)} test samples have no forecast "
            f"(all {H} steps, found by frame and id); --allow-missing scores the others"
        )
    if missing:
        samples, positions, now_m = samples.subset(found), positions[found], now_m[found]
    relative = positions - now_m[:, None, None].astype(np.float64)  # (S, K, H, 2) from now
    scores = file_scores(relative, samples, modes, read.files.label)
    scored: Scored = [(read.files.name, read.files.label, s) for s in scores]
    return samples, [*scored, (CONSTANT_VELOCITY, None, constant_velocity_scores(samples, H))]


def track_forecast_rows(
    sources: Sequence[TrackSource], read: ReadForecasts, modes: tuple[str, ...], data: DataConfig
) -> list[EvaluationResult]:
    """Rows of forecast files on recordings, as ``evaluate --tracks`` has a checkpoint's: per
    file and pooled, each with constant velocity's on the same samples (each recording's
    forecasts in the file named after it, or in the only file)."""
    files = [Path(source.path) for source in sources]
    samples = recording_samples(sources, data)
    scenes = recording_scenes(sources, data)
    kept, scored = scored_forecast_files(read, files, samples, modes, data, scenes=scenes)
    template = EvaluationResult("", CONSTANT_VELOCITY, None, 0, 0.0, 0.0)
    template = dataclasses.replace(template, derivatives=data.derivatives)
    rows = []
    for name, label, scores in scored:
        named = dataclasses.replace(template, model=name, checkpoint=label)
        rows += recording_rows(files, kept, scores, named)
    return rows
