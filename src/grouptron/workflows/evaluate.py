"""One ``evaluate`` for every source: the benchmark's test sets, track files of one's own, and
a dataset description's test part; a checkpoint's scores beside constant velocity's on the
same samples (or constant velocity alone), with its point forecast's prediction regions
(coverage and area per step) where asked.

    from grouptron.workflows.evaluate import Benchmark, evaluate
    rows = evaluate(Benchmark(splits=("univ",)), "grouptron-univ-backward", ("ml", "best-of-20"))
    papers = EvaluationOptions(metrics=("miss-rate-2m",))  # beside ADE and FDE, for this call
    rows = evaluate(Benchmark(), "grouptron-eth-central", ("best-of-5", "best-of-20"), papers)
    rows = evaluate(Tracks(("site.txt",)), options=EvaluationOptions(regions=(0.5, 0.9)))
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.constants import (
    CONSTANT_VELOCITY,
    EVALUATION_MODES,
    SPLITS,
)
from grouptron.data.datasets.custom import DatasetDescription, load_dataset_part
from grouptron.data.datasets.locate import resolve_data_dir, split_files
from grouptron.data.datasets.subsets import density_masks, time_step_ids
from grouptron.data.formats.track_files import TrackSource
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores, score_samples
from grouptron.evaluation.metrics import Metric, scoring
from grouptron.evaluation.recordings import evaluate_recordings, training_files
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.evaluation.results import EvaluationResult, mean_over_splits, score_rows
from grouptron.evaluation.test_sets import load_test_set
from grouptron.geometry import DerivativeScheme
from grouptron.groups.assign import SampleGroups
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model, uses_groups
from grouptron.model.forecaster import Forecaster
from grouptron.model.predict import ABLATIONS, default_point_forecast
from grouptron.point_forecast import is_evaluation_mode, is_sampled_mode
from grouptron.workflows.adapt import adapted_parts
from grouptron.workflows.evaluate_files import (
    ForecastFiles,
    ReadForecasts,
    read_forecasts,
    refuse_for_files,
    scored_forecast_files,
    track_forecast_rows,
)
from grouptron.workflows.evaluate_regions import refuse_meaningless_regions, region_scoring
from grouptron.workflows.held_out import (
    benchmark_splits,
    mark_not_held_out,
    seen_dataset_files,
    seen_splits,
    seen_track_names,
)

log = logging.getLogger("grouptron")


@dataclass(frozen=True)
class Benchmark:
    """The ETH/UCY test sets: ``splits`` (None: the checkpoint's own split, or all five for
    constant velocity), univ's UNIV-N ``subset`` (``univ-40``), from ``data_dir`` (None:
    ``$GROUPTRON_DATA``, else the download cache)."""

    splits: tuple[str, ...] | None = None
    subset: str | None = None
    data_dir: Path | None = None


@dataclass(frozen=True)
class Tracks:
    """Track files of one's own (ROS 2 bags too), each read as ``layout`` says (its ``path``
    aside; default: ETH/UCY's ``frame id x y`` rows)."""

    files: tuple[Path, ...]
    layout: TrackSource = field(default_factory=lambda: TrackSource(""))

    def __post_init__(self) -> None:
        files = (self.files,) if isinstance(self.files, str | Path) else tuple(self.files)
        if not files:
            raise GrouptronError("Tracks needs at least one track file")
        object.__setattr__(self, "files", tuple(Path(f) for f in files))

    @property
    def sources(self) -> tuple[TrackSource, ...]:
        """Every file with its layout."""
        return self.layout.files(self.files)


Source = Benchmark | Tracks | DatasetDescription


@dataclass(frozen=True)
class EvaluationOptions:
    """How to evaluate.

    Attributes:
        seed: of the sampled modes (best-of-K, NLL).
        by_density: add rows per density bin (neighbours within 3 m at t).
        ablate: inputs taken away from the model (``ABLATIONS``).
        derivatives: of constant velocity's samples (None: ``DataConfig``'s); a checkpoint
            brings its own, and a different one here is refused.
        on_gap: what a track that misses steps does (``split`` or ``error``).
        device: where the network runs.
        use_cache: read and keep samples and groups in the cache.
        progress: progress bars.
        regions: probabilities q of prediction regions to score each point forecast's by
            (coverage and area per step: ``coverage-q90``, ``area-q90``); empty: none.
        calibration: a ``grouptron calibrate`` file of the checkpoint and point forecast whose
            radii size the regions (None: the one the checkpoint ships with, where it fits
            every point forecast scored, as ``predict`` draws them; False: the model's own).
        include_seen: score data the checkpoint trained or validated on (another split's
            test set, say) instead of refusing, each such row marked ``held_out=False``.
        metrics: scored beside the registered ones (``miss-rate-2m``, ``module:name``, a
            ``Metric``: ``evaluation.metrics.resolve_metric``), for this evaluation only.
    """

    seed: int = 0
    by_density: bool = False
    ablate: tuple[str, ...] = ()
    derivatives: DerivativeScheme | None = None
    on_gap: Literal["split", "error"] = "split"
    device: str = "cpu"
    use_cache: bool = True
    progress: bool = False
    regions: tuple[float, ...] = ()
    calibration: str | Path | bool | None = None
    include_seen: bool = False
    metrics: tuple[str | Metric, ...] = ()


@dataclass(frozen=True)
class _Loaded:
    """A checkpoint's model and settings (both None for constant velocity alone)."""

    model: Forecaster | None
    experiment: ExperimentConfig | None
    data: DataConfig
    name: str | None
    path: Path | None = None
    forecasts: ReadForecasts | None = None
    """Forecast files made elsewhere, scored instead of a model."""


def evaluate(
    source: Source,
    checkpoint: str | Path | ForecastFiles | None = DEFAULT_CHECKPOINT,
    modes: Sequence[str] | None = None,
    options: EvaluationOptions = EvaluationOptions(),
) -> list[EvaluationResult]:
    """Rows of scores of ``checkpoint`` (a shipped name or a file; forecast files made
    elsewhere, on the benchmark's samples; None: constant velocity alone) on ``source``,
    constant velocity's rows beside them on the same samples, each mean with its 95% interval
    (time steps resampled). ``modes``: evaluation modes (default: the checkpoint's own point
    forecast, what ``predict`` writes). Every request is checked before anything is read, so
    Python callers get the command line's one-line errors."""
    _refuse_meaningless(source, checkpoint, modes, options)
    if isinstance(checkpoint, ForecastFiles):
        on_benchmark = isinstance(source, Tracks) or (
            isinstance(source, Benchmark) and bool(source.splits)
        )
        taken = bool(options.ablate or options.regions)
        refuse_for_files(on_benchmark, taken, modes)
    else:
        refuse_meaningless_regions(checkpoint, modes, options.regions, options.calibration)
    with scoring(options.metrics):  # the metrics asked, for this evaluation only
        loaded = _load(checkpoint, options)
        chosen = tuple(modes) if modes else _default_modes(loaded)
        _check_ablations(options.ablate, loaded)
        regions = region_scoring(
            loaded.experiment, loaded.path, chosen, options.regions, options.calibration
        )
        if isinstance(source, Tracks):
            return _evaluate_tracks(source, loaded, chosen, options, regions=regions)
        if isinstance(source, DatasetDescription):
            return _evaluate_dataset(source, loaded, chosen, options, regions=regions)
        return _evaluate_benchmark(source, loaded, chosen, options, regions=regions)


def _refuse_meaningless(
    source: Source,
    checkpoint: str | Path | ForecastFiles | None,
    modes: Sequence[str] | None,
    options: EvaluationOptions,
) -> None:
    """Refuse what has no meaning (unknown modes, sampled modes or ablations of constant
    velocity, the NLL of track files), before anything is read."""
    if isinstance(modes, str):
        raise GrouptronError(f"modes is a sequence of evaluation modes, not {modes!r}")
    unknown = [m for m in modes or () if not is_evaluation_mode(m)]
    if unknown:
        raise GrouptronError(
            f"unknown mode {', '.join(map(str, unknown))}; choose from "
            f"{', '.join(EVALUATION_MODES)}, ml-topK or best-of-K"
        )
    sampled = [m for m in modes or () if is_sampled_mode(m)]
    if checkpoint is None and sampled:
        raise GrouptronError(
            f"constant velocity makes one forecast: --mode {','.join(sampled)} needs a --checkpoint"
        )
    if checkpoint is None and options.ablate:
        raise GrouptronError("--ablate takes inputs away from a checkpoint's model")
    if isinstance(source, Tracks) and "nll" in (modes or ()):
        raise GrouptronError("--mode nll is scored on benchmark test sets, not on --tracks")


def _load(checkpoint: str | Path | ForecastFiles | None, options: EvaluationOptions) -> _Loaded:
    if checkpoint is None or isinstance(checkpoint, ForecastFiles):
        data = DataConfig(on_gap=options.on_gap)
        if options.derivatives:
            data = dataclasses.replace(data, derivatives=options.derivatives)
        if checkpoint is None:
            return _Loaded(None, None, data, None)
        return _Loaded(None, None, data, checkpoint.name, forecasts=read_forecasts(checkpoint))
    path = resolve_checkpoint(checkpoint)
    model, experiment = load_trained_model(path)
    data = dataclasses.replace(experiment.data, on_gap=options.on_gap)
    if options.derivatives and options.derivatives != data.derivatives:
        raise GrouptronError(
            f"{checkpoint} was trained with {data.derivatives} derivatives; evaluating it on "
            f"{options.derivatives} ones would be meaningless"
        )
    return _Loaded(model.to(options.device), experiment, data, str(checkpoint), path)


def _default_modes(loaded: _Loaded) -> tuple[str, ...]:
    if loaded.forecasts is not None:
        return loaded.forecasts.default_modes()
    experiment = loaded.experiment
    return (default_point_forecast(experiment).name,) if experiment is not None else ("ml",)


def _check_ablations(ablate: tuple[str, ...], loaded: _Loaded) -> None:
    unknown = sorted(set(ablate) - set(ABLATIONS))
    if unknown:
        raise GrouptronError(
            f"unknown --ablate {', '.join(unknown)}; choose from {', '.join(ABLATIONS)}"
        )
    if ablate and loaded.model is None:
        raise GrouptronError("--ablate takes inputs away from a checkpoint's model")
    grouped = loaded.experiment is not None and uses_groups(loaded.experiment)
    if "scene" in ablate and not grouped:
        raise GrouptronError("--ablate scene needs a Grouptron checkpoint (a scene encoding)")


def _model_scores(
    loaded: _Loaded,
    samples: SampleSet,
    groups: SampleGroups | None,
    modes: tuple[str, ...],
    options: EvaluationOptions,
    *,
    regions: RegionScoring | None,
) -> list[tuple[str, str | None, SampleScores]]:
    """(model name, checkpoint, scores) of the model per mode, then constant velocity's."""
    scored: list[tuple[str, str | None, SampleScores]] = []
    if loaded.model is not None and loaded.experiment is not None:
        suffix = f" without {' and '.join(options.ablate)}" if options.ablate else ""
        scored += [
            (loaded.experiment.model_name + suffix, loaded.name, scores)
            for scores in score_samples(
                loaded.model,
                loaded.experiment,
                samples,
                modes,
                seed=options.seed,
                progress=options.progress,
                groups=groups,
                ablate=options.ablate,
                device=options.device,
                regions=regions,
            )
        ]
    baseline = constant_velocity_scores(samples, loaded.data.horizon_steps)
    return [*scored, (CONSTANT_VELOCITY, None, baseline)]


def _rows(
    split: str,
    scored: list[tuple[str, str | None, SampleScores]],
    masks: dict[str | None, np.ndarray | None],
    derivatives: str,
    steps: np.ndarray,
) -> list[EvaluationResult]:
    """Rows per model, mode and subset, with 95% intervals over the (S,) time ``steps``."""
    rows = []
    for name, checkpoint, scores in scored:
        template = EvaluationResult(split, name, None, 0, 0.0, 0.0)
        template = dataclasses.replace(template, checkpoint=checkpoint, derivatives=derivatives)
        named = checkpoint is not None
        rows += score_rows(template, scores, masks, steps=steps, named_mode=named)
    return rows


def _evaluate_benchmark(
    source: Benchmark,
    loaded: _Loaded,
    modes: tuple[str, ...],
    options: EvaluationOptions,
    *,
    regions: RegionScoring | None,
) -> list[EvaluationResult]:
    """Every split's test set (and its UNIV-N subset), the mean over the five splits."""
    experiment = loaded.experiment
    splits, subset = benchmark_splits(
        source.splits, source.subset, experiment, loaded.name, include_seen=options.include_seen
    )
    data_dir = resolve_data_dir(source.data_dir)
    seen = seen_splits(experiment, loaded.name, data_dir, splits, options.include_seen)
    grouped = experiment is not None and uses_groups(experiment)
    group_config = experiment.groups if experiment is not None and grouped else None
    rows: list[EvaluationResult] = []
    kept: dict[tuple[str, str | None], list[tuple[SampleScores, np.ndarray]]] = {}
    for split in splits:
        samples, groups = load_test_set(
            data_dir,
            split,
            loaded.data,
            subset,
            group_config=group_config,
            use_cache=options.use_cache,
        )
        if loaded.forecasts is not None:  # made elsewhere: found by frame and id
            recordings = split_files(data_dir, split, "test")
            samples, scored = scored_forecast_files(
                dataclasses.replace(loaded.forecasts, single_split=len(splits) == 1),
                recordings,
                samples,
                modes,
                loaded.data,
            )
        else:
            scored = _model_scores(loaded, samples, groups, modes, options, regions=regions)
        masks: dict[str | None, np.ndarray | None] = {source.subset: None}
        masks.update(density_masks(samples) if options.by_density else {})
        rows += _rows(split, scored, masks, loaded.data.derivatives, time_step_ids(samples))
        for name, checkpoint, scores in scored:  # (model, row mode): its scores per split
            key = (name, scores.mode if checkpoint else None)
            kept.setdefault(key, []).append((scores, time_step_ids(samples)))
    rows = mark_not_held_out([r for r in rows if r.samples or r.subset is None], seen)
    if len(splits) == len(SPLITS) and not options.by_density:  # the mean, with intervals
        rows += [
            mean_over_splits([r for r in rows if (r.model, r.mode) == key], per_split)
            for key, per_split in kept.items()
        ]
    return rows


def _evaluate_tracks(
    source: Tracks,
    loaded: _Loaded,
    modes: tuple[str, ...],
    options: EvaluationOptions,
    *,
    regions: RegionScoring | None,
) -> list[EvaluationResult]:
    """Rows per file and pooled, with intervals; a file the checkpoint trained, validated or
    adapted on is named in a warning, and its rows (and the pooled ones) not held out."""
    if loaded.forecasts is not None:  # made elsewhere: found by the file's frame and id
        return track_forecast_rows(source.sources, loaded.forecasts, modes, loaded.data)
    seen: list[Path | str] = []
    if loaded.experiment is not None:
        if loaded.data.derivatives == "central":
            log.warning(
                "%s was trained with central derivatives: each forecast reads the position one "
                "step after the forecast time, which live data does not have; use a backward "
                "checkpoint for causal forecasts",
                loaded.name,
            )
        adapted = adapted_parts(loaded.path, source.files) if loaded.path else []
        seen += [path for path, _ in adapted]
        seen += training_files(source.files, loaded.experiment)
        for adapted_file, seconds in adapted:
            log.warning(
                "%s: its first %.0f s adapted %s: scores there are not held-out scores (score "
                "a later recording, or adapt with grouptron adapt --holdout-minutes)",
                adapted_file,
                seconds,
                loaded.name,
            )
        for path in training_files(source.files, loaded.experiment):
            log.warning(
                "%s is part of the data %s was trained or validated on (%s split): its scores "
                "are not held-out scores",
                path,
                loaded.name,
                loaded.experiment.split,
            )
    rows = evaluate_recordings(
        source.sources,
        model=loaded.model,
        experiment=loaded.experiment,
        data=loaded.data,
        modes=modes,
        seed=options.seed,
        progress=options.progress,
        device=options.device,
        by_density=options.by_density,
        ablate=options.ablate,
        baseline=loaded.model is not None,
        regions=regions,
    )
    return mark_not_held_out(rows, seen_track_names(seen))


def _evaluate_dataset(
    source: DatasetDescription,
    loaded: _Loaded,
    modes: tuple[str, ...],
    options: EvaluationOptions,
    *,
    regions: RegionScoring | None,
) -> list[EvaluationResult]:
    """The test part of a dataset of one's own (and its density bins)."""
    seen = seen_dataset_files(loaded.experiment, loaded.name, source, options.include_seen)
    part = load_dataset_part(source, "test", loaded.data, use_cache=options.use_cache)
    masks: dict[str | None, np.ndarray | None] = {None: None}
    masks.update(density_masks(part.samples) if options.by_density else {})
    groups = None
    if loaded.experiment is not None:
        groups = groups_for_model(part.samples, loaded.experiment)
    scored = _model_scores(loaded, part.samples, groups, modes, options, regions=regions)
    steps = time_step_ids(part.samples)
    rows = _rows(source.name, scored, masks, loaded.data.derivatives, steps)
    return mark_not_held_out(rows, {source.name} if seen else ())
