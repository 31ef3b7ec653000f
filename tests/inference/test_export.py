"""ONNX export: onnxruntime gives what PyTorch gives, on shipped checkpoints of both models."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.cli import main
from grouptron.config import DataConfig, ExperimentConfig, GroupEncoderConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.inference.checkpoints import resolve_checkpoint
from grouptron.inference.export import (
    ForecastNetwork,
    batch_inputs,
    export_onnx,
    run_onnx,
)
from grouptron.model.batch import make_batch
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import build_model, groups_for_model
from tests.golden.compute import synthetic_tracks
from tests.helpers.models import SMALL

onnx = pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")


def _batch_inputs(network: ForecastNetwork) -> dict[str, torch.Tensor]:
    """A batch unlike the one the export traced: 10 people of the golden scene, some with only
    a few observed steps, a crossing walker, a standing pair."""
    rows = synthetic_tracks()
    table = table_from_values(Path("golden"), rows, np.arange(len(rows)))
    config = network.config
    scene = build_scene(table, config.data)
    samples = scene_samples(scene, config.data, 2, require_future=False, only_step=10)
    data = config.data
    batch = make_batch(
        samples, np.arange(len(samples)), data, groups=groups_for_model(samples, config)
    )
    inputs = batch_inputs(batch, network.config)
    return dict(zip(network.input_names, inputs, strict=True))


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        "trajectron++-univ-backward",
        "grouptron-univ-backward",
        "grouptron-robust-univ-backward",
        "trajectron++-residual-univ-backward",
        "grouptron-robust-residual-crowds-backward",  # the default model
    ],
)
def test_onnxruntime_equals_pytorch_on_a_shipped_checkpoint(name: str, tmp_path: Path) -> None:
    _check_export(*load_trained_model(resolve_checkpoint(name)), tmp_path)


@pytest.mark.slow
def test_a_model_with_mean_edges_and_counts_exports_its_extra_input(tmp_path: Path) -> None:
    config = ExperimentConfig(
        model_name="grouptron",
        split="eth",
        model=dataclasses.replace(SMALL, edge_aggregation="mean", edge_count_feature=True),
        group_encoder=GroupEncoderConfig(group_dim=4),
        data=DataConfig(derivatives="backward"),
    )
    torch.manual_seed(0)
    names = _check_export(build_model(config).eval(), config, tmp_path)
    assert names[-1] == "nbr_count"


def _check_export(model: TrajectronCVAE, config: ExperimentConfig, tmp_path: Path) -> list[str]:
    out = tmp_path / "model.onnx"
    names = export_onnx(model, config, out)
    network = ForecastNetwork(model, config)
    inputs = _batch_inputs(network)
    assert list(inputs) == names and len(inputs["hist_st"]) == 10
    with torch.inference_mode():
        expected = [t.numpy() for t in network(*inputs.values())]
    got = run_onnx(out, {k: v.numpy() for k, v in inputs.items()})
    Z, H = config.model.latent_values, config.data.horizon_steps
    assert got[0].shape == (10, Z) and got[1].shape == (10, Z, H, 2)
    assert got[2].shape == (10, Z, H, 2, 2)
    for a, b in zip(expected, got, strict=True):
        np.testing.assert_allclose(b, a, atol=1e-4, rtol=0)
    np.testing.assert_allclose(np.exp(got[0]).sum(1), 1.0, rtol=1e-5)
    meta = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    assert meta["grouptron.model"] == config.model_name
    assert json.loads(meta["grouptron.inputs"]) == names
    assert json.loads(meta["grouptron.state_scale"]) == list(config.data.state_scale)
    return names


def test_export_without_the_extra_is_one_clear_error(
    tiny_checkpoints: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setitem(sys.modules, "onnxscript", None)  # as if not installed
    path = tiny_checkpoints / "grouptron-eth-backward"
    model, config = load_trained_model(resolve_checkpoint(path))
    with pytest.raises(GrouptronError, match=r"grouptron\[export\]"):
        export_onnx(model, config, tmp_path / "m.onnx")
    assert main(["export", "--checkpoint", str(path), "--out", str(tmp_path / "m.onnx")]) != 0
    assert "grouptron[export]" in capsys.readouterr().err
    assert not (tmp_path / "m.onnx").exists()


def test_export_refuses_a_folder_before_exporting(tiny_checkpoints: Path, tmp_path: Path) -> None:
    model, config = load_trained_model(
        resolve_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    )
    with pytest.raises(GrouptronError, match="is a folder"):
        export_onnx(model, config, str(tmp_path))  # a str path is taken too
