"""Shared fixtures: synthetic track files and, where present, the real benchmark copy."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def real_data_dir() -> Path | None:
    """The ETH/UCY copy named by $GROUPTRON_DATA or beside the checkout, if it exists."""
    candidates = [os.environ.get("GROUPTRON_DATA", ""), str(REPO.parent / "shared/data/eth_ucy")]
    for candidate in candidates:
        if candidate and (Path(candidate) / "SHA256SUMS").is_file():
            return Path(candidate)
    return None


@pytest.fixture(scope="session")
def eth_ucy_dir() -> Path:
    found = real_data_dir()
    if found is None:
        pytest.skip("ETH/UCY benchmark files not available (set GROUPTRON_DATA)")
    return found


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    """Keep every test's preprocessing cache out of the user's home."""
    monkeypatch.setenv("GROUPTRON_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def write_tracks(path: Path, rows: list[tuple[float, float, float, float]]) -> Path:
    """Write ``frame id x y`` rows tab-separated, as in the benchmark files."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(f"{f}\t{i}\t{x}\t{y}\n" for f, i, x, y in rows))
    return path


def synthetic_recording(path: Path, seed: int, pedestrians: int = 8, steps: int = 40) -> Path:
    """A recording of pedestrians walking roughly straight, some in pairs, entering at random."""
    import numpy as np

    rng = np.random.default_rng(seed)
    rows = []
    for ped in range(pedestrians):
        start = int(rng.integers(0, steps // 2))
        pos = rng.uniform(-4, 4, size=2)
        vel = rng.normal(0, 0.5, size=2)
        for step in range(start, steps):
            vel = vel + rng.normal(0, 0.03, size=2)
            pos = pos + vel * 0.4
            rows.append((step * 10, ped, round(float(pos[0]), 3), round(float(pos[1]), 3)))
    return write_tracks(path, rows)


@pytest.fixture(scope="session")
def synthetic_data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An ETH/UCY-shaped folder (split eth) of synthetic recordings."""
    root = tmp_path_factory.mktemp("synthetic")
    for part, seeds in {"train": (1, 2, 3), "val": (4,), "test": (5,)}.items():
        for seed in seeds:
            synthetic_recording(root / "eth" / part / f"scene{seed}.txt", seed)
    return root


@pytest.fixture(scope="session")
def tiny_checkpoints(synthetic_data_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A checkpoint folder laid out like ``checkpoints/``: tiny Trajectron++ and Grouptron
    models trained one epoch on the synthetic eth split (central derivatives), and a tiny
    backward-derivative Grouptron."""
    import dataclasses

    from grouptron.config import ExperimentConfig, GroupEncoderConfig, TrainConfig
    from grouptron.data.datasets.dataset import load_part
    from grouptron.groups.cache import load_groups
    from grouptron.training.trainer import train
    from tests.helpers.models import SMALL

    root = tmp_path_factory.mktemp("checkpoints")
    runs = [("trajectron++", "central"), ("grouptron", "central"), ("grouptron", "backward")]
    for model, protocol in runs:
        config = ExperimentConfig(
            model_name=model,
            data=dataclasses.replace(ExperimentConfig().data, derivatives=protocol),
            model=SMALL,
            group_encoder=GroupEncoderConfig(group_dim=4),
            train=TrainConfig(epochs=1, batch_size=64, threads=1),
        )
        parts = [
            load_part(synthetic_data_dir, "eth", p, config.data).samples for p in ("train", "val")
        ]
        groups = (
            [
                load_groups(
                    synthetic_data_dir, "eth", p, config.data, groups=config.groups, samples=s
                )
                for p, s in zip(("train", "val"), parts, strict=True)
            ]
            if model == "grouptron"
            else [None, None]
        )
        train(
            config,
            *parts,
            root / f"{model}-eth-{protocol}",
            progress=False,
            train_groups=groups[0],
            val_groups=groups[1],
        )
    return root
