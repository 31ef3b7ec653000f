"""Checkpoints round-trip and refuse pickles, truncation and mismatched weights."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import pytest
import torch
from safetensors import safe_open

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from grouptron.model.factory import build_model, load_weights
from tests.helpers.models import SMALL, random_batch

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


class _Payload:
    """A pickle that creates a file when unpickled: what a malicious checkpoint would do."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str]]:
        return (Path.touch, (str(self.marker),))  # type: ignore[return-value]


def _bad_checkpoints(folder: Path) -> dict[str, tuple[Path, str]]:
    """Damaged variants of a valid checkpoint, with the words their refusal must contain."""
    from safetensors.torch import load_file, save_file

    good = folder / "good.safetensors"
    save_checkpoint(good, Checkpoint(CONFIG, build_model(CONFIG).state_dict()))
    tensors = load_file(str(good))
    with safe_open(str(good), framework="pt") as handle:
        metadata = handle.metadata()
    cases: dict[str, tuple[dict[str, torch.Tensor], dict[str, str]] | bytes] = {}
    name = next(k for k in tensors if k.startswith("model.") and k.endswith("weight"))
    cases["extra"] = ({**tensors, "model.smuggled": torch.zeros(3)}, metadata)
    cases["missing"] = ({k: v for k, v in tensors.items() if k != name}, metadata)
    wider = dict(tensors)
    wider[name] = torch.zeros(tensors[name].shape[0] + 1, *tensors[name].shape[1:])
    cases["shape"] = (wider, metadata)
    poisoned = dict(tensors)
    poisoned[name] = tensors[name].clone()
    poisoned[name].view(-1)[0] = torch.nan
    cases["nan"] = (poisoned, metadata)
    cases["truncated"] = good.read_bytes()[:-100]
    cases["pickle"] = pickle.dumps(_Payload(folder / "pwned"))
    expected = {
        "extra": "unexpected tensors smuggled",
        "missing": f"missing tensors {name[6:]}",
        "shape": "shapes do not match",
        "nan": "not finite",
        "truncated": "truncated",
        "pickle": "never unpickles",
    }
    out: dict[str, tuple[Path, str]] = {}
    for case, content in cases.items():
        path = folder / f"{case}.safetensors"
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            save_file(content[0], str(path), metadata=content[1])
        out[case] = (path, expected[case])
    return out


def test_every_damaged_checkpoint_is_refused_in_one_line(tmp_path: Path) -> None:
    from grouptron.cli import main
    from grouptron.model.checkpoint import load_trained_model
    from tests.conftest import synthetic_recording

    tracks = synthetic_recording(tmp_path / "tracks.txt", seed=1)
    for case, (path, fragment) in _bad_checkpoints(tmp_path).items():
        with pytest.raises(GrouptronError, match=fragment) as info:
            load_trained_model(path)
        assert "\n" not in str(info.value) and str(path) in str(info.value), case
        out = tmp_path / f"{case}.csv"
        argv = ["predict", "--checkpoint", str(path), "--tracks", str(tracks), "--out", str(out)]
        assert main([*argv, "--quiet"]) == 2, case
        assert not out.exists(), case
    assert not (tmp_path / "pwned").exists()  # the pickle's payload never ran


def test_stored_configs_of_older_runs_keep_the_inputs_they_were_trained_on() -> None:
    from grouptron.config import experiment_from_stored

    legacy = experiment_from_stored(
        {"data": {"derivatives": "backward"}, "model": {"group_dim": 8}}
    )
    assert legacy.data.future_scale_m == 3.0 and legacy.data.backward_start == "next"
    assert legacy.group_encoder.group_dim == 8
    newer = experiment_from_stored({"data": {"derivatives": "backward", "future_scale_m": 1.0}})
    assert newer.data.backward_start == "zero" and newer.data.future_scale_m == 1.0


def test_settings_stored_under_an_older_name_are_read_under_todays() -> None:
    from grouptron.config import experiment_from_stored, renamed_settings
    from grouptron.errors import GrouptronError

    stored = {"model": {"latent_modes": 7, "decoder_hidden": 16}}
    assert experiment_from_stored(stored).model.latent_values == 7
    assert renamed_settings(stored) == {"model": {"latent_values": 7, "decoder_hidden": 16}}
    assert stored == {"model": {"latent_modes": 7, "decoder_hidden": 16}}  # left as it was
    with pytest.raises(GrouptronError, match=r"latent_modes and model\.latent_values are one"):
        renamed_settings({"model": {"latent_modes": 7, "latent_values": 7}})
