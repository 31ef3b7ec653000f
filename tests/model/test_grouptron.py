"""Grouptron's encoders: graph convolutions, masks, singleton groups, batching, training."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.cli import main
from grouptron.config import (
    DataConfig,
    ExperimentConfig,
    GroupConfig,
    GroupEncoderConfig,
)
from grouptron.data.datasets.dataset import load_part
from grouptron.groups.assign import assign_groups
from grouptron.model.batch import make_batch
from grouptron.model.factory import build_model
from grouptron.model.stgcn import STGCNBlock, segment_graph_conv, segment_mean
from grouptron.presets import experiment_preset
from tests.helpers.models import SMALL

# Two samples: sample 0 has groups {0, 1} and {2}; sample 1 has group {3} alone.
SEGMENT = torch.tensor([0, 0, 1, 2])
FEATURES = torch.tensor([1.0, 3.0, 5.0, 7.0]).reshape(4, 1, 1).expand(4, 2, 1).clone()
MASK = torch.ones(4, 2, dtype=torch.bool)


def test_sym_norm_graph_conv_is_the_group_mean_and_a_singleton_keeps_itself() -> None:
    out = segment_graph_conv(FEATURES, MASK, SEGMENT, 3, adjacency="sym_norm")
    torch.testing.assert_close(out[:, 0, 0], torch.tensor([2.0, 2.0, 5.0, 7.0]))


def test_laplacian_graph_conv_is_zero_for_a_singleton() -> None:
    out = segment_graph_conv(FEATURES, MASK, SEGMENT, 3, adjacency="laplacian")
    torch.testing.assert_close(out[:, 0, 0], torch.tensor([-2.0, 2.0, 0.0, 0.0]))


def test_masked_members_are_left_out_of_the_graph_and_the_mean() -> None:
    mask = MASK.clone()
    mask[1, 0] = False  # member 1 not yet observed at step 0
    out = segment_graph_conv(FEATURES, mask, SEGMENT, 3, adjacency="sym_norm")
    assert out[0, 0, 0] == 1.0 and out[1, 0, 0] == 0.0 and out[0, 1, 0] == 2.0
    mean, exists = segment_mean(FEATURES, mask, SEGMENT, 3)
    assert mean[0, 0, 0] == 1.0 and mean[0, 1, 0] == 2.0 and exists.all()


@pytest.mark.parametrize("adjacency", ["sym_norm", "laplacian"])
def test_stgcn_block_shapes_and_masks(adjacency: str) -> None:
    torch.manual_seed(0)
    block = STGCNBlock(6, 16, adjacency)  # type: ignore[arg-type]
    x = torch.randn(5, 8, 6)
    mask = torch.ones(5, 8, dtype=torch.bool)
    mask[4, :3] = False
    out = block(x, mask, torch.tensor([0, 0, 1, 1, 2]), 3)
    assert out.shape == (5, 8, 16)
    assert (out[4, :3] == 0).all() and out[4, 3:].abs().sum() > 0


def synthetic_batch(root: Path, config: ExperimentConfig, count: int = 48):
    samples = load_part(root, "eth", "train", config.data).samples
    groups = assign_groups(samples, config.groups, config.data.position_scale_m)
    index = np.arange(count)
    return samples, groups, make_batch(samples, index, config.data, np.zeros(count), groups=groups)


def test_group_batch_layout(synthetic_data_dir: Path) -> None:
    config = ExperimentConfig(model_name="grouptron")
    samples, groups, batch = synthetic_batch(synthetic_data_dir, config)
    assert batch.groups is not None
    g = batch.groups
    counts = samples.num_neighbours[:48] + 1
    assert g.node_st.shape == (counts.sum(), 8, 6)
    assert g.num_groups == int(groups.num_groups[:48].sum())
    np.testing.assert_array_equal(np.bincount(g.group_sample.numpy()), groups.num_groups[:48])
    # Every ego is node 0 of its sample and sits in its ego group.
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    np.testing.assert_array_equal(g.node_group[first].numpy(), g.ego_group.numpy())
    assert (g.node_st[first, -1] == 0).all()  # the ego relative to itself at t


def test_rotating_the_batch_does_not_change_the_groups(synthetic_data_dir: Path) -> None:
    config = ExperimentConfig(model_name="grouptron")
    samples, groups, plain = synthetic_batch(synthetic_data_dir, config)
    turned = make_batch(samples, np.arange(48), config.data, np.full(48, 1.0), groups=groups)
    assert plain.groups is not None and turned.groups is not None
    torch.testing.assert_close(turned.groups.node_group, plain.groups.node_group)
    # Rotation keeps lengths of every (x, y) pair.
    torch.testing.assert_close(
        turned.groups.node_st[..., :2].norm(dim=-1), plain.groups.node_st[..., :2].norm(dim=-1)
    )


def test_grouptron_forward_adds_the_scene_encoding(synthetic_data_dir: Path) -> None:
    torch.manual_seed(0)
    config = ExperimentConfig(
        model_name="grouptron", model=SMALL, group_encoder=GroupEncoderConfig(group_dim=4)
    )
    _, _, batch = synthetic_batch(synthetic_data_dir, config)
    model = build_model(config)
    out = model(batch, logit_clip=1.0)
    assert out.encoding.x.shape == (48, 8 + 8 + 4)
    assert out.velocity.mean.shape == (48, 5, 12, 2)
    trajectron = build_model(dataclasses.replace(config, model_name="trajectron++"))
    assert trajectron(batch).encoding.x.shape == (48, 16)  # encoders switched off


def test_eth_preset_narrows_the_group_encoders_of_grouptron_only() -> None:
    assert experiment_preset("eth", "grouptron").group_encoder.group_dim == 8
    assert experiment_preset("univ", "grouptron").group_encoder.group_dim == 16
    assert experiment_preset("eth", "trajectron++") == ExperimentConfig(split="eth")
    assert GroupConfig().linkage in ("single", "average", "complete")
    assert DataConfig().derivatives == "central"


def test_train_and_evaluate_grouptron_end_to_end(
    synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.json"
    tiny = {f.name: getattr(SMALL, f.name) for f in dataclasses.fields(SMALL)}
    config.write_text(
        json.dumps(
            {
                "model_name": "grouptron",
                "model": tiny,
                "group_encoder": {"group_dim": 4},
                "train": {"batch_size": 64},
            }
        )
    )
    out = tmp_path / "run"
    common = ["--data-dir", str(synthetic_data_dir), "--quiet"]
    assert (
        main(
            [
                "train",
                "--split",
                "eth",
                "--model",
                "grouptron",
                "--epochs",
                "2",
                "--config",
                str(config),
                "--out",
                str(out),
                *common,
            ]
        )
        == 0
    )
    records = [json.loads(line) for line in (out / "metrics.jsonl").open()]
    assert len(records) == 2 and records[1]["train_loss"] < records[0]["train_loss"]
    capsys.readouterr()
    argv = ["evaluate", "--checkpoint", str(out / "best.safetensors"), "--format", "json"]
    assert main([*argv, *common]) == 0
    row, baseline = json.loads(capsys.readouterr().out)["results"]
    # The model's own point forecast (ml-argmax for a decoder without the velocity residual).
    assert row["model"] == "grouptron" and row["mode"] == "ml-argmax" and row["ade"] > 0
    assert baseline["model"] == "constant-velocity" and baseline["samples"] == row["samples"]
