"""Training end to end on small data: resume is exact, loss goes down, overfitting works."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
import torch

from grouptron.config import ExperimentConfig, load_config
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import load_checkpoint
from grouptron.training.trainer import BEST, LAST, train
from tests.helpers.data import tiny_parts
from tests.helpers.models import TINY


def test_killed_and_resumed_run_ends_at_the_same_weights(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    train_set, val_set = tiny_parts(synthetic_data_dir)
    per_epoch = math.ceil(len(train_set) / TINY.train.batch_size)
    full = train(TINY, train_set, val_set, tmp_path / "full", progress=False)
    assert full.iteration == 2 * per_epoch
    # Killed two steps into epoch 2: only epoch 1 was saved.
    train(
        TINY, train_set, val_set, tmp_path / "resumed", progress=False, max_iterations=per_epoch + 2
    )
    assert load_checkpoint(tmp_path / "resumed" / LAST).epoch == 1
    resumed = train(TINY, train_set, val_set, tmp_path / "resumed", resume=True, progress=False)
    assert resumed.iteration == full.iteration
    for name, value in full.model.state_dict().items():
        assert torch.equal(value, resumed.model.state_dict()[name]), name
    records = [json.loads(line) for line in (tmp_path / "resumed/metrics.jsonl").open()]
    assert [r["epoch"] for r in records] == [1, 2]
    assert (tmp_path / "full" / BEST).exists()


def test_resume_refuses_another_config_and_a_fresh_run_refuses_an_old_folder(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    train_set, val_set = tiny_parts(synthetic_data_dir)
    one = dataclasses.replace(TINY, train=dataclasses.replace(TINY.train, epochs=1))
    train(one, train_set, val_set, tmp_path, progress=False)
    with pytest.raises(GrouptronError, match="already holds a training run"):
        train(one, train_set, val_set, tmp_path, progress=False)
    other = dataclasses.replace(one, train=dataclasses.replace(one.train, learning_rate=0.1))
    with pytest.raises(GrouptronError, match="different configuration"):
        train(other, train_set, val_set, tmp_path, resume=True, progress=False)
    with pytest.raises(GrouptronError, match="nothing to resume"):
        train(one, train_set, val_set, tmp_path / "empty", resume=True, progress=False)


def test_warm_start_continues_weights_and_schedule_under_another_protocol(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    train_set, val_set = tiny_parts(synthetic_data_dir)
    one = dataclasses.replace(TINY, train=dataclasses.replace(TINY.train, epochs=1))
    source = train(one, train_set, val_set, tmp_path / "central", progress=False)
    backward = dataclasses.replace(
        one,
        data=dataclasses.replace(one.data, derivatives="backward"),
        train=dataclasses.replace(one.train, init_from=str(tmp_path / "central" / LAST)),
    )
    moved = train(
        backward, *tiny_parts(synthetic_data_dir, backward), tmp_path / "b", progress=False
    )
    assert moved.epoch == 1 and moved.iteration == 2 * source.iteration
    assert moved.optimizer.param_groups[0]["lr"] < source.optimizer.param_groups[0]["lr"]
    assert load_config(ExperimentConfig, tmp_path / "b" / "config.json") == backward
    card = (tmp_path / "b" / "README.md").read_text()
    assert "backward derivatives (causal)" in card and "started from" in card
    assert "training state (its optimiser and step count continue)" in card
    assert "| epochs trained | 1 (" in card and "cpu:" in card
    records = [json.loads(line) for line in (tmp_path / "b/metrics.jsonl").open()]
    assert records[0]["epoch_seconds"] >= records[0]["train_seconds"] > 0
    # The source must be of the same architecture.
    wrong = dataclasses.replace(
        backward, model=dataclasses.replace(backward.model, latent_values=3)
    )
    with pytest.raises(GrouptronError, match="same architecture"):
        train(wrong, train_set, val_set, tmp_path / "g", progress=False)
    weights_only = dataclasses.replace(
        backward,
        train=dataclasses.replace(backward.train, init_from=str(tmp_path / "central" / BEST)),
    )
    # Weights only: a fine-tune with a fresh optimiser and step count.
    tuned = train(
        weights_only, *tiny_parts(synthetic_data_dir, backward), tmp_path / "w", progress=False
    )
    assert tuned.iteration == source.iteration
    assert tuned.optimizer.param_groups[0]["lr"] == pytest.approx(
        one.train.learning_rate * one.train.lr_decay_per_iter**tuned.iteration
    )


def test_fine_tuning_a_weights_only_checkpoint_uses_a_fresh_optimiser_at_the_given_lr(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    from grouptron.cli import main

    source = tiny_checkpoints / "trajectron++-eth-central"
    out = tmp_path / "tuned"
    argv = ["train", "--split", "eth", "--config", str(source / "config.json"), "--epochs", "1"]
    argv += ["--init-from", str(source / BEST), "--lr", "0.0005", "--out", str(out)]
    argv += ["--data-dir", str(synthetic_data_dir), "--quiet", "--precision", "fp32"]
    assert main(argv) == 0
    (record,) = [json.loads(line) for line in (out / "metrics.jsonl").open()]
    steps = record["iteration"]
    assert steps < 20  # a fresh step count, not the source run's
    assert record["learning_rate"] == pytest.approx(0.0005 * 0.9999**steps)
    assert record["initialised_from"].startswith("weights (fresh optimiser")
    card = (out / "README.md").read_text()
    assert f"started from `{source / BEST}` (weights (fresh optimiser" in card
    assert "`train.learning_rate = 0.0005`" in card
