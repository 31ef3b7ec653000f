"""The five leave-one-location-out splits as cached sample sets."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, config_to_dict
from grouptron.data.datasets.locate import preprocessed_cache_dir, split_files
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.reader import read_tracks
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import SampleSet, concatenate_samples, scene_samples
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.io import keep_cache_npz, read_cache_npz

CACHE_FORMAT_VERSION = 5  # 3: causal backward derivatives; 4: one-point tracks kept there;
# 5: scene_index counts files once (it was doubled)
"""Bump when the content of cached sample sets changes."""


@dataclass(frozen=True)
class SceneSummary:
    """Counts describing one scene, kept with the cached samples."""

    name: str
    num_tracks: int
    num_steps: int
    max_present: int


@dataclass(frozen=True)
class PartData:
    """The samples and scene summaries of one part (train, val or test) of a split."""

    samples: SampleSet
    scenes: tuple[SceneSummary, ...]


def min_history_for(part: str, config: DataConfig) -> int:
    """Observed points a sample needs: all ``history_steps`` for test, fewer for train/val."""
    return config.history_steps if part == "test" else config.min_history_train


def load_scenes(
    files: list[Path], config: DataConfig, recording: RecordingFormat | None = None
) -> list[Scene]:
    """Read and build the scenes of a list of track files: ETH/UCY ``frame id x y`` files, or
    recordings laid out as ``recording`` says (resampled to the step)."""
    if recording is None:
        tables = [read_tracks(f, config.frames_per_step, config.on_gap) for f in files]
    else:
        sources = [TrackSource.from_format(f, recording) for f in files]
        tables = [
            read_track_file(replace(s, on_gap=config.on_gap), config.frames_per_step, config.dt_s)[
                0
            ]
            for s in sources
        ]
    return [build_scene(table, config) for table in tables]


def build_part(
    files: list[Path],
    config: DataConfig,
    min_history: int,
    recording: RecordingFormat | None = None,
) -> PartData:
    """Samples of several scene files, uncached."""
    scenes = load_scenes(files, config, recording)
    samples = concatenate_samples(
        [scene_samples(s, config, min_history) for s in scenes]  # renumbered by concatenating
    )
    summaries = tuple(
        SceneSummary(s.name, s.num_tracks, s.num_steps, int(s.present_per_step().max()))
        for s in scenes
    )
    return PartData(samples, summaries)


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def cache_key(
    files: list[Path],
    config: DataConfig,
    min_history: int,
    recording: RecordingFormat | None = None,
) -> str:
    """Hash of the input files' contents, their layout, the data settings and the cache
    format."""
    settings = config_to_dict(config)
    if config.neighbour_window_steps == (0, 0):  # keys from before the setting stay valid
        del settings["neighbour_window_steps"]
    payload: dict[str, object] = {
        "format": CACHE_FORMAT_VERSION,
        "config": settings,
        "min_history": min_history,
        "files": [[f.name, _file_digest(f)] for f in files],
    }
    if recording is not None:
        layout = dataclasses.asdict(recording)
        del layout["spelling"]  # how messages name options; the samples are the same
        payload["recording"] = layout
        payload["reader"] = 2  # 2: an empty comma-separated field is refused, not merged
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:32]


def _part_arrays(part: PartData) -> dict[str, np.ndarray]:
    arrays = {f"samples.{k}": v for k, v in part.samples.to_arrays().items()}
    arrays["scenes.name"] = np.asarray([s.name for s in part.scenes])
    for field in ("num_tracks", "num_steps", "max_present"):
        arrays[f"scenes.{field}"] = np.asarray([getattr(s, field) for s in part.scenes])
    return arrays


def _parse_part(arrays: dict[str, np.ndarray]) -> PartData:
    samples = SampleSet.from_arrays(
        {k.removeprefix("samples."): v for k, v in arrays.items() if k.startswith("samples.")}
    )
    scenes = tuple(
        SceneSummary(str(name), int(tracks), int(steps), int(present))
        for name, tracks, steps, present in zip(
            arrays["scenes.name"],
            arrays["scenes.num_tracks"],
            arrays["scenes.num_steps"],
            arrays["scenes.max_present"],
            strict=True,
        )
    )
    return PartData(samples, scenes)


def cache_path(split: str, part: str, config: DataConfig, key: str) -> Path:
    """The ``.npz`` file caching one part's samples, named by split, part, derivatives
    and ``key``."""
    return preprocessed_cache_dir() / f"{split}-{part}-{config.derivatives}-{key}.npz"


def load_part(
    data_dir: Path, split: str, part: str, config: DataConfig, *, use_cache: bool = True
) -> PartData:
    """Samples of one part of an ETH/UCY split, from the on-disk cache when it is there.

    The cache key hashes the files' contents and the config, so edited files or a different
    derivative scheme never reuse stale samples. Cache files are ``.npz`` read without pickle.
    """
    files = split_files(data_dir, split, part)
    return load_files_part(files, split, part, config, use_cache=use_cache)


def load_files_part(
    files: list[Path],
    name: str,
    part: str,
    config: DataConfig,
    *,
    recording: RecordingFormat | None = None,
    use_cache: bool = True,
) -> PartData:
    """Samples of a part made of ``files`` (cached under ``name``), see :func:`load_part`."""
    min_history = min_history_for(part, config)
    if not use_cache:
        return build_part(files, config, min_history, recording)
    key = cache_key(files, config, min_history, recording)
    path = cache_path(name, part, config, key)
    stored = read_cache_npz(path, _parse_part)
    if stored is not None:
        return stored
    data = build_part(files, config, min_history, recording)
    keep_cache_npz(path, _part_arrays(data))
    return data
