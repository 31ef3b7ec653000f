"""Grouptron's variant switches (GroupEncoderConfig): each changes what it says and nothing
when off (the paper's model and its checkpoints stay as they are)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.config import ExperimentConfig, GroupEncoderConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.groups.assign import assign_groups
from grouptron.model.batch import Batch, make_batch
from grouptron.model.elbo import elbo_loss
from grouptron.model.factory import build_model
from grouptron.model.noise import draw_training_noise
from tests.golden.compute import synthetic_tracks
from tests.helpers.models import SMALL, TINY_MODEL


def _config(**variant: object) -> ExperimentConfig:
    return dataclasses.replace(
        ExperimentConfig(model_name="grouptron", split="eth", model=SMALL),
        group_encoder=GroupEncoderConfig(group_dim=8, **variant),  # type: ignore[arg-type]
    )


@pytest.fixture(scope="module")
def batch() -> Batch:
    """The golden scene at step 8 (full futures): nine people, walking groups, a standing
    pair, a late arrival."""
    rows = synthetic_tracks()
    config = _config()
    scene = build_scene(table_from_values(Path("s"), rows, np.arange(len(rows))), config.data)
    samples = scene_samples(scene, config.data, 2, only_step=8)
    groups = assign_groups(samples, config.groups, config.data.position_scale_m)
    return make_batch(samples, np.arange(len(samples)), config.data, groups=groups)


def _scene_encoding(config: ExperimentConfig, batch: Batch) -> torch.Tensor:
    torch.manual_seed(0)
    model = build_model(config).eval()
    with torch.no_grad():
        return model.encode_scene(batch)  # type: ignore[operator]


def _perturbed(batch: Batch, step: int, *, nodes: torch.Tensor | None = None) -> Batch:
    """``batch`` with the node states at ``step`` moved (all nodes, or those given)."""
    assert batch.groups is not None
    node_st = batch.groups.node_st.clone()
    chosen = slice(None) if nodes is None else nodes
    node_st[chosen, step] += 0.7
    return dataclasses.replace(batch, groups=dataclasses.replace(batch.groups, node_st=node_st))


def test_the_paper_encoders_never_see_the_oldest_step_and_three_dilated_layers_do(
    batch: Batch,
) -> None:
    moved = _perturbed(batch, step=0)  # t-7
    for layers, sees in ((1, False), (3, True)):
        config = _config(temporal_layers=layers)
        before, after = _scene_encoding(config, batch), _scene_encoding(config, moved)
        assert before.shape == (len(batch), 8)
        assert (not torch.allclose(before, after)) == sees, layers
    assert not torch.allclose(  # and the paper's block does see the last steps
        _scene_encoding(_config(), batch), _scene_encoding(_config(), _perturbed(batch, step=7))
    )


def test_leaving_the_ego_out_of_its_group_stops_e_scene_copying_it(batch: Batch) -> None:
    assert batch.groups is not None
    ego_node = torch.zeros(len(batch.groups.node_group), dtype=torch.bool)
    node_sample = batch.groups.group_sample[batch.groups.node_group]
    ego_node[0], ego_node[1:] = True, node_sample[1:] != node_sample[:-1]
    # a sample whose ego is alone in its group
    alone = [
        b
        for b in range(len(batch))
        if int((batch.groups.node_group == batch.groups.ego_group[b]).sum()) == 1
    ]
    assert alone
    moved = _perturbed(batch, step=7, nodes=ego_node)  # only the egos move
    for in_own, copies in ((True, True), (False, False)):
        config = _config(ego_in_own_group=in_own)
        before, after = _scene_encoding(config, batch), _scene_encoding(config, moved)
        changed = ~torch.isclose(before[alone], after[alone]).all(dim=-1)
        assert bool(changed.all()) == copies and bool(changed.any()) == copies


def test_norm_count_feature_and_dropout_shapes(batch: Batch) -> None:
    config = _config(scene_layer_norm=True, count_feature=True, scene_dropout_keep=0.5)
    torch.manual_seed(0)
    model = build_model(config)
    assert model.condition_dim == model.base_condition_dim + 9  # E_scene and log(1 + groups)
    assert model.extra_dropout_sizes() == {"scene": 9}
    model.eval()
    with torch.no_grad():
        encoding = model.encode_scene(batch)  # type: ignore[operator]
    assert encoding.shape == (len(batch), 9) and torch.isfinite(encoding).all()
    norm = encoding[:, :8]
    torch.testing.assert_close(norm.mean(-1), torch.zeros(len(batch)), atol=1e-5, rtol=0)
    groups = torch.bincount(batch.groups.group_sample, minlength=len(batch))  # type: ignore[union-attr]
    torch.testing.assert_close(encoding[:, 8], torch.log1p(groups.float()))
    # One training step with every switch on: a finite loss, gradients in the new layers.
    model.train()
    noise = draw_training_noise(len(batch), config.model, 12, model.extra_dropout_sizes())
    output = model(batch, noise, logit_clip=None)
    loss = elbo_loss(output, batch, config.loss, 1.0, dt_s=0.4).loss
    loss.backward()
    assert torch.isfinite(loss)
    assert model.scene_norm.weight.grad is not None  # type: ignore[union-attr]


def test_a_variant_dropout_site_leaves_the_other_draws_as_they_were() -> None:
    torch.manual_seed(3)
    plain = draw_training_noise(4, SMALL, 12)
    torch.manual_seed(3)
    extra = draw_training_noise(4, SMALL, 12, {"scene": 8})
    for site, values in plain.dropout.items():
        torch.testing.assert_close(extra.dropout[site], values)
    torch.testing.assert_close(extra.decoder, plain.decoder)
    assert extra.dropout["scene"].shape == (4, 8)


def test_variant_settings_are_checked() -> None:
    for bad in ({"temporal_layers": 0}, {"scene_dropout_keep": 0.0}):
        with pytest.raises(GrouptronError, match=next(iter(bad))):
            GroupEncoderConfig(**bad)  # type: ignore[arg-type]


def test_every_screened_variant_is_a_valid_configuration(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The screening campaign's switches are settings `grouptron config show` accepts."""
    from grouptron.cli import main

    for model, switches in _screen_module().VARIANTS.values():  # type: ignore[attr-defined]
        argv = ["config", "show", "--model", model, "--split", "univ", "--changes"]
        for switch in switches:
            argv += ["--set", switch]
        assert main(argv) == 0
        shown = capsys.readouterr().out
        for switch in switches:
            assert switch.split("=")[0] in shown


def _screen_module() -> object:
    import importlib.util

    from tests.conftest import REPO

    spec = importlib.util.spec_from_file_location("screen", REPO / "campaign" / "screen.py")
    assert spec is not None and spec.loader is not None
    screen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(screen)
    return screen


def _assert_named_is_screened(variant: str, name: str) -> None:
    """The named model's preset equals the screening variant's switches on univ and eth."""
    from grouptron.cli.train import parse_setting
    from grouptron.config import config_from_dict, merge_settings
    from grouptron.presets import experiment_preset, preset_values

    model, switches = _screen_module().VARIANTS[variant]  # type: ignore[attr-defined]
    for split in ("univ", "eth"):
        values = preset_values(split, model)
        for switch in switches:
            values = merge_settings(values, parse_setting(switch))
        screened = config_from_dict(ExperimentConfig, values)
        assert experiment_preset(split, name) == dataclasses.replace(screened, model_name=name)


def test_the_named_variant_is_the_screened_robust_switches() -> None:
    """`grouptron-robust` is exactly Grouptron with the screened `robust` switches, so that a
    screening run and a run of the named model train the same network."""
    from grouptron.config import config_from_dict
    from grouptron.model.factory import uses_groups
    from grouptron.model.grouptron import GrouptronCVAE
    from grouptron.presets import experiment_preset, preset_values

    _assert_named_is_screened("robust", "grouptron-robust")
    assert experiment_preset("eth", "grouptron-robust").group_encoder.group_dim == 8
    assert experiment_preset("univ", "grouptron-robust").group_encoder.group_dim == 16
    assert experiment_preset("univ", "grouptron").group_encoder.temporal_layers == 1
    own = config_from_dict(ExperimentConfig, preset_values("eth", "grouptron-robust", "own.toml"))
    assert own.group_encoder.group_dim == 16 and own.group_encoder.temporal_layers == 3
    assert uses_groups(own) and isinstance(build_model(own), GrouptronCVAE)


def test_the_residual_model_is_the_screened_residual_switch() -> None:
    """`trajectron++-residual` is Trajectron++ (no group encoders) with the screened velocity
    residual, on the benchmark's splits and on a dataset of one's own."""
    from grouptron.config import config_from_dict
    from grouptron.model.cvae import TrajectronCVAE
    from grouptron.model.factory import uses_groups
    from grouptron.model.grouptron import GrouptronCVAE
    from grouptron.presets import preset_values

    _assert_named_is_screened("trajectron++-residual", "trajectron++-residual")
    own = config_from_dict(
        ExperimentConfig, preset_values("eth", "trajectron++-residual", "own.toml")
    )
    built = build_model(own)
    assert own.model.velocity_residual and not uses_groups(own)
    assert isinstance(built, TrajectronCVAE) and not isinstance(built, GrouptronCVAE)


def test_the_group_residual_model_is_the_screened_robust_residual_switches() -> None:
    """`grouptron-robust-residual` is Grouptron with the screened `robust-residual` switches:
    the group encoders, the robust settings (eth's narrow ST-GCNs too) and the residual."""
    from grouptron.model.factory import uses_groups
    from grouptron.model.grouptron import GrouptronCVAE
    from grouptron.presets import MODEL_PRESETS, experiment_preset

    _assert_named_is_screened("robust-residual", "grouptron-robust-residual")
    univ = experiment_preset("univ", "grouptron-robust-residual")
    assert univ.model.velocity_residual and univ.group_encoder.temporal_layers == 3
    assert experiment_preset("eth", "grouptron-robust-residual").group_encoder.group_dim == 8
    assert uses_groups(univ) and isinstance(build_model(univ), GrouptronCVAE)
    assert "velocity_residual" not in MODEL_PRESETS["grouptron-robust"]["model"]  # untouched


@pytest.mark.slow
def test_the_named_variant_trains_and_evaluates_from_the_cli(
    synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`grouptron train --model grouptron-robust` (threshold groups, cached by their settings,
    included), then `evaluate` of its checkpoint: the card names the model and its switches."""
    import json
    import math

    from grouptron.cli import main

    config = tmp_path / "tiny.json"
    config.write_text(json.dumps({"model": TINY_MODEL, "train": {"batch_size": 64}}))
    out = tmp_path / "variant"
    common = ["--data-dir", str(synthetic_data_dir), "--quiet"]
    argv = ["train", "--split", "eth", "--model", "grouptron-robust", "--derivatives", "backward"]
    argv += ["--epochs", "1", "--config", str(config), "--out", str(out)]
    assert main([*argv, *common]) == 0
    capsys.readouterr()
    card = (out / "README.md").read_text()
    assert "Grouptron (robust)" in card
    assert "temporal_layers" in card and "max_distance_m" in card
    evaluate = ["evaluate", "--checkpoint", str(out / "best.safetensors"), *common]
    assert main([*evaluate, "--format", "json"]) == 0
    row, baseline = json.loads(capsys.readouterr().out)["results"]
    assert row["model"] == "grouptron-robust" and math.isfinite(row["fde"])
    assert baseline["model"] == "constant-velocity"  # beside it, on the same samples
