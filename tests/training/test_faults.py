"""Training survives faults: SIGKILL mid-epoch and mid-checkpoint, non-finite steps, a full disk."""

from __future__ import annotations

import dataclasses
import errno
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest
import torch

from grouptron.cli import main
from grouptron.config import ExperimentConfig, TrainConfig, save_config
from grouptron.errors import GrouptronError
from grouptron.model import checkpoint as checkpoint_module
from grouptron.model import cvae as cvae_module
from grouptron.model.checkpoint import load_checkpoint
from grouptron.model.elbo import LossTerms
from grouptron.training.trainer import LAST, train
from tests.conftest import REPO
from tests.helpers.data import tiny_parts
from tests.helpers.models import SMALL

CONFIG = ExperimentConfig(model=SMALL, train=TrainConfig(epochs=3, batch_size=64, threads=1))
STEPS_PER_EPOCH = 7  # 411 synthetic training samples in batches of 64

# Runs `grouptron train` in a child process that kills itself with SIGKILL at a chosen moment:
# after a given optimiser step, or halfway through writing a given checkpoint file.
KILLER = textwrap.dedent(
    """
    import os, signal, sys
    import torch
    from grouptron.model import checkpoint
    from grouptron.cli import main

    mode, when, argv = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    if mode == "step":
        step = torch.optim.Adam.step
        calls = [0]

        def killing_step(self, *args, **kwargs):
            calls[0] += 1
            if calls[0] == when:
                os.kill(os.getpid(), signal.SIGKILL)
            return step(self, *args, **kwargs)

        torch.optim.Adam.step = killing_step
    else:
        save_file = checkpoint.save_file
        writes = [0]

        def killing_save(tensors, filename, metadata=None):
            if os.path.basename(filename).startswith(".last.safetensors"):
                writes[0] += 1
                if writes[0] == when:
                    save_file(tensors, filename, metadata=metadata)
                    size = os.path.getsize(filename)
                    with open(filename, "r+b") as handle:  # half of it reached the disk
                        handle.truncate(size // 2)
                    os.kill(os.getpid(), signal.SIGKILL)
            return save_file(tensors, filename, metadata=metadata)

        checkpoint.save_file = killing_save
    sys.exit(main(argv))
    """
)


def _train_argv(config_file: Path, data_dir: Path, out: Path) -> list[str]:
    return [
        "train",
        "--config",
        str(config_file),
        "--split",
        "eth",
        "--data-dir",
        str(data_dir),
        "--out",
        str(out),
        "--quiet",
    ]


def _killed(mode: str, when: int, argv: list[str]) -> None:
    child = subprocess.run(
        [sys.executable, "-c", KILLER, mode, str(when), *argv],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert child.returncode == -9, child.stderr[-2000:]  # died by SIGKILL, not otherwise


def _weights(run: Path) -> dict[str, torch.Tensor]:
    return load_checkpoint(run / LAST).model_state


@pytest.mark.slow
def test_sigkill_mid_epoch_and_mid_checkpoint_then_resume_ends_at_the_same_weights(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    config_file = tmp_path / "config.json"
    save_config(CONFIG, config_file)
    assert main(_train_argv(config_file, synthetic_data_dir, tmp_path / "whole")) == 0
    run = tmp_path / "killed"
    argv = _train_argv(config_file, synthetic_data_dir, run)

    _killed("step", STEPS_PER_EPOCH + 3, argv)  # three steps into epoch 2
    assert load_checkpoint(run / LAST).epoch == 1

    # Resumed, then killed while writing epoch 2's checkpoint: epoch 1's file is untouched.
    _killed("save", 1, [*argv, "--resume"])
    assert load_checkpoint(run / LAST).epoch == 1
    assert list(run.glob(".last.safetensors.*.tmp"))  # the half-written temporary

    assert main([*argv, "--resume"]) == 0
    assert load_checkpoint(run / LAST).epoch == 3
    assert not list(run.glob(".*.tmp"))  # cleaned up on resume
    whole, resumed = _weights(tmp_path / "whole"), _weights(run)
    assert whole.keys() == resumed.keys()
    for name, value in whole.items():
        assert torch.equal(value, resumed[name]), name


def _poisoned_loss(bad_calls: dict[int, str]) -> Any:
    """elbo_loss whose result is made NaN (``"loss"``) or gets inf gradients (``"grad"``) on
    the given calls (1-based)."""
    real = cvae_module.elbo_loss
    calls = [0]

    class InfiniteGradient(torch.autograd.Function):
        @staticmethod
        def forward(ctx: Any, value: torch.Tensor) -> torch.Tensor:
            return value.clone()

        @staticmethod
        def backward(ctx: Any, grad: torch.Tensor) -> torch.Tensor:
            return grad * torch.inf

    def poisoned(*args: Any, **kwargs: Any) -> LossTerms:
        terms = real(*args, **kwargs)
        calls[0] += 1
        kind = bad_calls.get(calls[0])
        if kind == "loss":
            return dataclasses.replace(terms, loss=terms.loss * torch.nan)
        if kind == "grad":
            return dataclasses.replace(terms, loss=InfiniteGradient.apply(terms.loss))
        return terms

    return poisoned


def test_nonfinite_steps_are_skipped_counted_and_stop_the_run(
    synthetic_data_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = dataclasses.replace(CONFIG, train=dataclasses.replace(CONFIG.train, epochs=1))
    train_set, val_set = tiny_parts(synthetic_data_dir, config)
    monkeypatch.setattr(cvae_module, "elbo_loss", _poisoned_loss({2: "loss", 5: "grad"}))
    state = train(config, train_set, val_set, tmp_path / "skips", progress=False)
    assert state.nonfinite_steps == 2
    assert state.iteration == STEPS_PER_EPOCH - 2  # the skipped steps changed nothing
    assert state.history[-1]["nonfinite_steps"] == 2
    assert all(torch.isfinite(p).all() for p in state.model.parameters())
    assert load_checkpoint(tmp_path / "skips" / LAST).extra["nonfinite_steps"] == 2

    strict = dataclasses.replace(
        config, train=dataclasses.replace(config.train, max_nonfinite_steps=1)
    )
    monkeypatch.setattr(cvae_module, "elbo_loss", _poisoned_loss({1: "grad", 3: "loss"}))
    with pytest.raises(GrouptronError, match=r"training stopped: 2 steps with non-finite"):
        train(strict, train_set, val_set, tmp_path / "strict", progress=False)


def test_a_full_disk_keeps_the_previous_checkpoint(
    synthetic_data_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = dataclasses.replace(CONFIG, train=dataclasses.replace(CONFIG.train, epochs=2))
    train_set, val_set = tiny_parts(synthetic_data_dir, config)
    real = checkpoint_module.save_file
    writes = [0]

    def fills_the_disk(tensors: Any, filename: str, metadata: Any = None) -> None:
        writes[0] += "last.safetensors" in filename
        if writes[0] > 1:  # epoch 1 wrote its last.safetensors; epoch 2 finds the disk full
            with open(filename, "wb") as handle:
                handle.write(b"\0" * 100)
            raise OSError(errno.ENOSPC, "No space left on device", filename)
        real(tensors, filename, metadata=metadata)

    monkeypatch.setattr(checkpoint_module, "save_file", fills_the_disk)
    run = tmp_path / "full-disk"
    with pytest.raises(GrouptronError, match=r"No space left on device.*is kept as it was"):
        train(config, train_set, val_set, run, progress=False)
    assert load_checkpoint(run / LAST).epoch == 1
    assert not list(run.glob(".*.tmp"))
