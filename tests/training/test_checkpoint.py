"""Checkpoints round-trip and refuse pickles, truncation and mismatched weights."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import pytest
import torch

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.factory import build_model, load_weights
from grouptron.training.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from tests.model.test_cvae import SMALL, random_batch

CONFIG = ExperimentConfig(model=SMALL)


def test_round_trip_with_optimizer_and_rng(tmp_path: Path) -> None:
    torch.manual_seed(0)
    model = build_model(CONFIG)
    optimizer = torch.optim.Adam(model.parameters())
    model(random_batch()).velocity.mean.sum().backward()
    optimizer.step()
    path = tmp_path / "ckpt.safetensors"
    rng_state = torch.get_rng_state()
    save_checkpoint(
        path,
        Checkpoint(
            CONFIG, model.state_dict(), 3, 42, optimizer.state_dict(), {"note": [1, 2]}, rng_state
        ),
    )
    loaded = load_checkpoint(path)
    assert loaded.config == CONFIG and (loaded.epoch, loaded.iteration) == (3, 42)
    assert loaded.extra == {"note": [1, 2]}
    for name, value in model.state_dict().items():
        torch.testing.assert_close(loaded.model_state[name], value)
    fresh = torch.optim.Adam(build_model(CONFIG).parameters())
    assert loaded.optimizer_state is not None
    fresh.load_state_dict(loaded.optimizer_state)
    torch.testing.assert_close(
        fresh.state_dict()["state"][0]["exp_avg"], optimizer.state_dict()["state"][0]["exp_avg"]
    )
    assert loaded.torch_rng_state is not None
    assert torch.equal(loaded.torch_rng_state, rng_state)
    assert not list(tmp_path.glob(".*tmp"))


def test_refuses_a_pickle_and_says_why(tmp_path: Path) -> None:
    path = tmp_path / "evil.pt"
    torch.save({"weights": torch.zeros(2)}, path)
    with pytest.raises(GrouptronError, match="never unpickles"):
        load_checkpoint(path)
    raw = tmp_path / "evil.pkl"
    raw.write_bytes(pickle.dumps({"a": 1}))
    with pytest.raises(GrouptronError, match="never unpickles"):
        load_checkpoint(raw)


def test_refuses_truncated_and_foreign_files(tmp_path: Path) -> None:
    path = tmp_path / "ckpt.safetensors"
    save_checkpoint(path, Checkpoint(CONFIG, build_model(CONFIG).state_dict()))
    data = path.read_bytes()
    (tmp_path / "cut.safetensors").write_bytes(data[: len(data) // 2])
    with pytest.raises(GrouptronError, match="truncated"):
        load_checkpoint(tmp_path / "cut.safetensors")
    from safetensors.torch import save_file

    save_file({"x": torch.zeros(1)}, str(tmp_path / "other.safetensors"))
    with pytest.raises(GrouptronError, match="does not name the grouptron format"):
        load_checkpoint(tmp_path / "other.safetensors")
    with pytest.raises(GrouptronError, match="not found"):
        load_checkpoint(tmp_path / "missing.safetensors")


def test_weights_that_do_not_fit_the_config_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "ckpt.safetensors"
    save_checkpoint(path, Checkpoint(CONFIG, build_model(CONFIG).state_dict()))
    loaded = load_checkpoint(path)
    wider = build_model(
        dataclasses.replace(CONFIG, model=dataclasses.replace(SMALL, decoder_hidden=32))
    )
    with pytest.raises(GrouptronError, match="shapes do not match"):
        load_weights(wider, loaded.model_state, str(path))
    partial = dict(loaded.model_state)
    partial.pop(next(iter(partial)))
    with pytest.raises(GrouptronError, match="missing tensors"):
        load_weights(build_model(CONFIG), partial, str(path))


def test_refuses_bad_metadata_and_configs(tmp_path: Path) -> None:
    from safetensors.torch import save_file

    base = {"format": "grouptron-checkpoint", "config": "{}", "epoch": "0", "iteration": "0"}
    for changes, fragment in [
        ({"format_version": "x"}, "bad metadata"),
        ({"config": "[1]"}, "must be a table of settings"),
        ({"config": '{"train": {"threads": 0}}'}, "threads must be >= 1"),
    ]:
        path = tmp_path / "c.safetensors"
        save_file({"model.w": torch.zeros(1)}, str(path), metadata={**base, **changes})
        with pytest.raises(GrouptronError, match=fragment):
            load_checkpoint(path)
