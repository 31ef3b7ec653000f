"""Tracks, scenes and sample sets that several test modules build the same way."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.samples import SampleSet
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from tests.conftest import write_tracks
from tests.helpers.models import TINY

DATA_CONFIG = DataConfig()


def walking_scene(tmp_path: Path, config: DataConfig = DATA_CONFIG) -> Scene:
    """Pedestrian 1 walks along y=0 at 1 m/s over steps 0..24; pedestrian 2 walks beside it at
    y=1 from step 3; pedestrian 3 is 10 m away; pedestrian 4 is seen once (dropped)."""
    rows = []
    for step in range(25):
        rows.append((step * 10, 1, 0.4 * step, 0.0))
        rows.append((step * 10, 3, 0.4 * step, 10.0))
        if step >= 3:
            rows.append((step * 10, 2, 0.4 * step, 1.0))
    rows.append((50, 4, 0.0, 5.0))
    table = read_tracks(write_tracks(tmp_path / "walk.txt", rows))
    return build_scene(table, config)


def walking_tracks(
    pedestrians: int, steps: int, seed: int, speed: float, offset: float
) -> np.ndarray:
    """(R, 4) rows frame, id, x, y of people walking straight from random starts."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(0, 8, (pedestrians, 2)) + offset
    heading = rng.uniform(0, 2 * np.pi, pedestrians)
    velocity = speed * np.stack([np.cos(heading), np.sin(heading)], 1)
    k = np.arange(steps)
    xy = start[:, None] + velocity[:, None] * 0.4 * k[None, :, None]  # (P, K, 2)
    frame = np.broadcast_to(k * 10, (pedestrians, steps))
    ids = np.broadcast_to(np.arange(pedestrians)[:, None], (pedestrians, steps))
    return np.column_stack([frame.ravel(), ids.ravel(), xy.reshape(-1, 2)])


def tiny_parts(root: Path, config: ExperimentConfig = TINY) -> tuple[SampleSet, SampleSet]:
    """The eth training and validation samples under ``root``."""
    return (
        load_part(root, "eth", "train", config.data).samples,
        load_part(root, "eth", "val", config.data).samples,
    )


def eth_test_samples(
    checkpoints: Path, data_dir: Path
) -> tuple[TrajectronCVAE, ExperimentConfig, SampleSet]:
    """The tiny Trajectron++ eth checkpoint and the synthetic eth test samples."""
    model, config = load_trained_model(checkpoints / "trajectron++-eth-central/best.safetensors")
    return model, config, load_part(data_dir, "eth", "test", config.data).samples
