"""The learned baselines: their step Gaussians (likelihood, draws and exact position
distribution), Social-STGCNN's graph (the paper's inverse-distance kernel, observed people
only, the forecast person in slot 0, blind to the neighbours' order), and both trained,
evaluated and loaded by name through the commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.baselines.social_stgcnn import SocialSTGCNN, node_graphs
from grouptron.baselines.step_gaussians import StepGaussians
from grouptron.baselines.transformer import TrajectoryTransformer
from grouptron.cli import main
from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch, GroupBatch
from grouptron.model.factory import build_model

T, H = 8, 12


def _gaussians(batch: int = 3, seed: int = 0) -> StepGaussians:
    gen = torch.Generator().manual_seed(seed)
    raw = torch.randn(batch, H, 5, generator=gen, dtype=torch.float64)
    return StepGaussians.from_raw(raw, 0.01)


def test_the_likelihood_is_each_steps_bivariate_normal() -> None:
    gaussians = _gaussians()
    future = torch.randn(3, H, 2, dtype=torch.float64).cumsum(dim=1)
    steps = future - torch.cat([torch.zeros(3, 1, 2, dtype=future.dtype), future[:, :-1]], 1)
    entries = gaussians.step_covariances()
    covariance = torch.stack(
        [torch.stack([entries[..., 0], entries[..., 1]], -1), entries[..., 1:]], -2
    )
    normal = torch.distributions.MultivariateNormal(gaussians.mean_m, covariance)
    expected = -normal.log_prob(steps).sum(dim=-1)
    assert torch.allclose(gaussians.negative_log_likelihood(future), expected)


def test_draws_follow_the_exact_position_distribution() -> None:
    gaussians = _gaussians(batch=2, seed=1)
    draws = gaussians.sample(40_000, torch.Generator().manual_seed(0))  # (B, K, H, 2)
    point = gaussians.point()
    assert torch.allclose(draws.mean(dim=1), point.point, atol=0.05 * H**0.5)
    centred = draws - draws.mean(dim=1, keepdim=True)
    var_x = (centred[..., 0] ** 2).mean(dim=1)
    cov_xy = (centred[..., 0] * centred[..., 1]).mean(dim=1)
    exact = point.gaussians.covariances[:, 0]  # (B, H, 3)
    assert torch.allclose(var_x, exact[..., 0], rtol=0.05)
    assert torch.allclose(cov_xy, exact[..., 1], atol=0.05 * exact[..., 0].max().item())


def _neighbourhood(order: tuple[int, ...] = (0, 1, 2)) -> Batch:
    """One sample: the ego walking east at 1 m/s, a neighbour 2 m north walking with it, a
    second 4 m east standing, seen only at the last two steps (nodes in ``order`` after the
    ego). States are standardised relative to the ego's at t (3 m, 2 m/s)."""
    ego = torch.zeros(T, 6)
    ego[:, 0] = (torch.arange(T) - (T - 1)) * 0.4 / 3.0  # positions up to now
    ego[:, 2] = 0.5  # 1 m/s east
    walker = ego.clone()
    walker[:, 1] = 2.0 / 3.0
    walker[:, 2] = 0.0  # relative to the ego's velocity: the same
    standing = torch.zeros(T, 6)
    standing[:, 0] = 4.0 / 3.0
    standing[:, 2] = -0.5  # 0 m/s, relative to the ego's 1 m/s
    ego_node = ego.clone()
    ego_node[:, 2:] -= ego[-1:, 2:]
    others = [walker, standing]
    masks = [torch.ones(T, dtype=torch.bool), torch.arange(T) >= T - 2]
    nodes = torch.stack([ego_node, *(others[i - 1] for i in order[1:])])
    mask = torch.stack([torch.ones(T, dtype=torch.bool), *(masks[i - 1] for i in order[1:])])
    return Batch(
        hist_st=ego[None],
        hist_mask=torch.ones(1, T, dtype=torch.bool),
        nbr_sum_st=torch.zeros(1, T, 6),
        edge_scale=torch.ones(1),
        fut_rel_m=torch.zeros(1, H, 2),
        fut_st=torch.zeros(1, H, 2),
        groups=GroupBatch(
            node_st=nodes,
            node_mask=mask,
            node_group=torch.zeros(len(order), dtype=torch.int64),
            group_sample=torch.zeros(1, dtype=torch.int64),
            ego_group=torch.zeros(1, dtype=torch.int64),
        ),
    )


def test_the_graph_weighs_observed_people_by_inverse_distance() -> None:
    graphs = node_graphs(_neighbourhood(), ExperimentConfig())
    step = graphs.displacement_m[0]  # (T, N, 2)
    assert torch.allclose(step[:, 0], torch.tensor([0.4, 0.0]).expand(T, 2))  # 1 m/s x 0.4 s
    assert torch.allclose(step[:, 1], torch.tensor([0.4, 0.0]).expand(T, 2))
    assert torch.allclose(step[:-2, 2], torch.zeros(T - 2, 2))  # unseen: no displacement
    weights = torch.tensor([[1.0, 0.5, 0.25], [0.5, 1.0, 1 / np.hypot(4, 2)], [0.25, 0, 1.0]])
    weights[2, 1] = weights[1, 2]
    scale = weights.sum(dim=1).rsqrt()
    expected = scale[:, None] * weights * scale[None]
    assert torch.allclose(graphs.adjacency[0, -1], expected.float(), atol=1e-6)
    early = graphs.adjacency[0, 0]  # the standing person not yet seen: no edges to it
    assert early[0, 2] == 0 and early[1, 2] == 0 and early[2, 2] == 1


def test_social_stgcnn_does_not_read_the_order_of_the_neighbours() -> None:
    torch.manual_seed(0)
    model = SocialSTGCNN(ExperimentConfig(model_name="social-stgcnn"))
    first = model.step_gaussians(_neighbourhood((0, 1, 2))).mean_m
    swapped = model.step_gaussians(_neighbourhood((0, 2, 1))).mean_m
    assert torch.allclose(first, swapped, atol=1e-6)
    alone = model.step_gaussians(_neighbourhood((0,))).mean_m
    assert not torch.allclose(first, alone, atol=1e-4)  # the neighbours do count


def test_baselines_are_built_by_name_and_refuse_unknown_settings() -> None:
    assert isinstance(build_model(ExperimentConfig(model_name="social-stgcnn")), SocialSTGCNN)
    transformer = build_model(ExperimentConfig(model_name="transformer"))
    assert isinstance(transformer, TrajectoryTransformer)
    with pytest.raises(GrouptronError, match="transformer"):
        build_model(ExperimentConfig(model_name="transformer", model_settings={"depth": 3}))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["social-stgcnn", "transformer"])
def test_a_baseline_trains_evaluates_and_forecasts_by_name(
    name: str, synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / name
    data = ["--split", "eth", "--data-dir", str(synthetic_data_dir)]
    train = ["train", "--model", name, *data, "--epochs", "2", "--out", str(run)]
    assert main([*train, "--quiet", "--precision", "fp32"]) == 0
    checkpoint = str(run / "best.safetensors")
    capsys.readouterr()
    evaluate = ["evaluate", "--checkpoint", checkpoint, *data, "--mode", "ml,best-of-20"]
    assert main([*evaluate, "--format", "json"]) == 0
    rows = {r.get("mode"): r for r in json.loads(capsys.readouterr().out)["results"]}
    assert rows["best-of-20"]["fde"] < rows["ml"]["fde"]  # 20 draws beat their mean path
    assert np.isfinite(rows["ml"]["ade"])
    out = tmp_path / "forecasts.csv"
    track = next((synthetic_data_dir / "eth" / "test").glob("*.txt"))
    predict = ["predict", "--checkpoint", checkpoint, "--tracks", str(track), "--out", str(out)]
    assert main(predict) == 0
    assert len(out.read_text().splitlines()) > 1
