"""The model learns: the loss falls on a real split, and a tiny model overfits 64 samples."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.config import ExperimentConfig, LossConfig, ModelConfig, TrainConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.evaluation.evaluate import evaluate_model
from grouptron.training.trainer import train

pytestmark = [pytest.mark.realdata, pytest.mark.slow]


def test_loss_falls_on_the_real_eth_split(eth_ucy_dir: Path, tmp_path: Path) -> None:
    config = ExperimentConfig(train=TrainConfig(epochs=3, batch_size=64))
    samples = load_part(eth_ucy_dir, "eth", "train", config.data).samples
    subset = samples.subset(np.random.default_rng(0).random(len(samples)) < 0.05)  # ~1900
    train(config, subset, subset.subset(np.zeros(len(subset), bool)), tmp_path, progress=False)
    records = [json.loads(line) for line in (tmp_path / "metrics.jsonl").open()]
    assert records[-1]["iteration"] == 3 * -(-len(subset) // 64)
    losses = [r["train_loss"] for r in records]
    assert losses[2] < losses[1] < losses[0]
    assert losses[2] < losses[0] - 10.0


def test_tiny_model_overfits_64_samples(eth_ucy_dir: Path, tmp_path: Path) -> None:
    config = ExperimentConfig(
        model=ModelConfig(
            history_hidden=32,
            edge_hidden=16,
            future_hidden=16,
            latent_values=5,
            p_z_hidden=16,
            decoder_hidden=32,
            rnn_dropout_keep=1.0,
            mlp_dropout_keep=1.0,
        ),
        loss=LossConfig(log_likelihood_max=100.0),  # let it fit tighter than the clamp allows
        train=TrainConfig(
            epochs=400,
            batch_size=64,
            learning_rate=1e-2,
            lr_decay_per_iter=1.0,
            rotation_augmentation=False,
        ),
    )
    test = load_part(eth_ucy_dir, "eth", "test", config.data).samples
    few = test.subset(np.arange(len(test)) < 64)
    state = train(config, few, few.subset(np.zeros(64, bool)), tmp_path, progress=False)
    (scores,) = evaluate_model(state.model, config, few, ("ml",))
    baseline = constant_velocity(few.hist_rel_m.astype(np.float64), 12)
    cv_ade = float(np.linalg.norm(baseline - few.fut_rel_m, axis=-1).mean())
    assert scores.ade < 0.3 * cv_ade  # about 0.1 m against 0.55 m
