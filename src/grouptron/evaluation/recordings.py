"""Scores on recordings of one's own: every (agent, step) of the given files with all observed
and future points after resampling to the model's step, one row per file and one pooled."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.constants import ALL_LOCATIONS, CONSTANT_VELOCITY, SPLITS
from grouptron.data.datasets.custom import DatasetDescription, read_dataset
from grouptron.data.datasets.download import file_sha256, shipped_checksums
from grouptron.data.datasets.locate import split_files
from grouptron.data.datasets.subsets import density_masks, time_step_ids
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import SampleSet, concatenate_samples, scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import SampleScores, constant_velocity_scores, score_samples
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.evaluation.results import EvaluationResult, score_rows
from grouptron.model.factory import groups_for_model
from grouptron.model.forecaster import Forecaster
from grouptron.model.predict import Ablation

POOLED = "all files"
REPOSITORY = Path(__file__).resolve().parents[3]
"""The repository of a source checkout (``src/grouptron/evaluation/`` is three below it)."""


def recording_samples(sources: Sequence[TrackSource], config: DataConfig) -> SampleSet:
    """The test-like samples (all ``history_steps`` observed, a full future) of every file,
    one scene per file (``scene_index`` = the file's position in ``sources``)."""
    parts = []
    for source in sources:
        source = dataclasses.replace(source, on_gap=config.on_gap)
        table, _ = read_track_file(source, config.frames_per_step, config.dt_s)
        scene = build_scene(table, config, name=Path(source.path).name)
        parts.append(scene_samples(scene, config, config.history_steps))  # renumbered below
    samples = concatenate_samples(parts)
    if not len(samples):
        raise GrouptronError(
            f"no pedestrian in {', '.join(str(s.path) for s in sources)} has "
            f"{config.history_steps} observed and {config.horizon_steps} future steps of "
            f"{config.dt_s} s"
        )
    return samples


def training_files(files: Sequence[Path], experiment: ExperimentConfig) -> list[str]:
    """The given files that are (byte for byte) ETH/UCY data the checkpoint was trained or
    validated on: a file of its split's train/val parts, or a whole recording of a location
    other than its split's test location (every ETH/UCY file for an all-locations model); for
    a run on a dataset of one's own, the files of its description's train and val parts
    (where the description is on this machine). Scores on them are not held-out scores."""
    if experiment.dataset:
        return _dataset_files(files, experiment.dataset)
    names_of: dict[str, list[str]] = {}
    for name, digest in shipped_checksums().items():
        names_of.setdefault(digest, []).append(name)
    found = []
    for path in files:
        for name in names_of.get(file_sha256(Path(path)), []):
            folder, part = Path(name).parts[-3:-1] if len(Path(name).parts) >= 3 else ("", "")
            seen_in_split = folder == experiment.split and part in ("train", "val")
            if experiment.split == ALL_LOCATIONS:  # every ETH/UCY recording, in part or whole
                seen_in_split = True
            whole = Path(name).parts[-2] == "all_data" and _in_training(name, experiment.split)
            if seen_in_split or whole:
                found.append(str(path))
                break
    return found


def benchmark_seen(experiment: ExperimentConfig, data_dir: Path, split: str) -> str | None:
    """Why the test recordings of benchmark ``split`` are not held out from the checkpoint
    ``experiment`` describes, or None where they are. A benchmark split leaves one location
    out, so a checkpoint of one split trained and validated on every other split's test
    location (hotel's test file holds the very tracks of eth's hotel train and val files); an
    all-locations checkpoint on all of them; a checkpoint of a dataset of one's own on those
    its train and val parts hold (all of them where its description cannot be read here: what
    it trained on is unknown), and any checkpoint on a file that is, byte for byte, ETH/UCY
    data it trained on (:func:`training_files`)."""
    if experiment.split == ALL_LOCATIONS:
        return "it trained on every ETH/UCY location"
    if experiment.split in SPLITS and experiment.split != split:
        return f"its {experiment.split} split trains and validates on {split}'s test location"
    if experiment.dataset and _description(experiment.dataset) is None:
        return (
            f"its dataset description {experiment.dataset} cannot be read: what it saw is unknown"
        )
    seen = training_files(split_files(data_dir, split, "test"), experiment)
    if seen:
        return f"it trained or validated on {Path(seen[0]).name}"
    return None


def _dataset_files(files: Sequence[Path], description: str) -> list[str]:
    """The given files that are (byte for byte) in a dataset's train or val part (a shipped
    checkpoint names its description relative to the repository, wherever one runs from)."""
    dataset = _description(description)
    if dataset is None:  # trained elsewhere: its description is not on this machine
        return []
    sizes = {Path(path).stat().st_size for path in files}  # only files of a size given are read
    trained = [f for part in ("train", "val") for f in dataset.parts.get(part, ())]
    seen = {file_sha256(f) for f in trained if f.stat().st_size in sizes}
    return [str(path) for path in files if file_sha256(Path(path)) in seen]


def _description(description: str) -> DatasetDescription | None:
    """A run's dataset description (a shipped checkpoint names it relative to the repository,
    wherever one runs from), or None where it cannot be read on this machine."""
    path = Path(description)
    in_repository = REPOSITORY / path
    if not path.is_absolute() and not path.exists() and in_repository.exists():
        path = in_repository
    try:
        return read_dataset(path)
    except GrouptronError:
        return None


def _in_training(all_data_name: str, split: str) -> bool:
    """Whether a whole recording (``all_data``) feeds the training part of ``split``: every
    location except the split's own test location."""
    test_files = {
        "eth": ("biwi_eth",),
        "hotel": ("biwi_hotel",),
        "univ": ("students001", "students003"),
        "zara1": ("crowds_zara01",),
        "zara2": ("crowds_zara02",),
    }[split]
    return not Path(all_data_name).stem.startswith(test_files)


def recording_rows(
    files: Sequence[Path],
    samples: SampleSet,
    scores: SampleScores,
    template: EvaluationResult,
    by_density: bool = False,
) -> list[EvaluationResult]:
    """One row per file and the pooled row, each with 95% intervals over time steps; with
    ``by_density`` also a pooled row per density bin (its name in ``subset``)."""
    steps = time_step_ids(samples)
    named = template.model != CONSTANT_VELOCITY
    Masks = dict[str | None, np.ndarray | None]
    per_file: list[tuple[str, Masks]] = [
        (Path(f).name, {None: samples.scene_index == i}) for i, f in enumerate(files)
    ]
    pooled: Masks = {None: None}
    if by_density:
        pooled.update(density_masks(samples))
    rows = []
    for name, found in [*per_file, (POOLED, pooled)]:
        masks = {k: m for k, m in found.items() if m is None or m.any()}
        rows += score_rows(
            dataclasses.replace(template, split=name),
            scores,
            masks,
            steps=steps,
            named_mode=named,
        )
    return rows


def evaluate_recordings(  # noqa: PLR0913 - the model and scoring options, all keyword-only
    sources: Sequence[TrackSource],
    *,
    model: Forecaster | None,
    experiment: ExperimentConfig | None,
    data: DataConfig,
    modes: tuple[str, ...] = ("ml",),
    seed: int = 0,
    progress: bool = False,
    device: torch.device | str = "cpu",
    by_density: bool = False,
    ablate: Ablation = (),
    baseline: bool = False,
    regions: RegionScoring | None = None,
) -> list[EvaluationResult]:
    """Constant velocity (``model`` None) or a checkpoint on the files: rows per file and mode,
    then the pooled row (and its density bins with ``by_density``); ``baseline`` adds constant
    velocity's rows on the same samples after the model's. ``data`` is the checkpoint's data
    settings (or the baseline's); the network runs on ``device`` with the ``ablate`` inputs
    taken away; ``regions``: the point forecasts' prediction regions to score too."""
    samples = recording_samples(sources, data)
    files = [Path(source.path) for source in sources]
    template = EvaluationResult("", CONSTANT_VELOCITY, None, 0, 0.0, 0.0)
    template = dataclasses.replace(template, derivatives=data.derivatives)
    if model is None or experiment is None:
        scores = constant_velocity_scores(samples, data.horizon_steps)
        return recording_rows(files, samples, scores, template, by_density)
    groups = groups_for_model(samples, experiment)
    rows = []
    per_mode = score_samples(
        model.to(device),
        experiment,
        samples,
        modes,
        seed=seed,
        progress=progress,
        groups=groups,
        device=device,
        ablate=ablate,
        regions=regions,
    )
    name = experiment.model_name + (f" without {' and '.join(ablate)}" if ablate else "")
    for scores in per_mode:
        named = dataclasses.replace(template, model=name)
        rows += recording_rows(files, samples, scores, named, by_density)
    if baseline:
        scores = constant_velocity_scores(samples, data.horizon_steps)
        rows += recording_rows(files, samples, scores, template, by_density)
    return rows
