"""Social-STGCNN (Mohamed et al., CVPR 2020) on the forecaster interface: a learned baseline
of the graph family.

Each sample's graph holds the person forecast and their neighbours (the people within the
perception radius at ``t``, as every model here reads them: the causal protocol). A node's
input at each observed step is its displacement over that step (metres); the edges of a step
weigh two people observed then by the inverse of their distance (the paper's kernel
``1 / ||p_i - p_j||``), self-loops added and the matrix normalised symmetrically. One
spatio-temporal graph convolution (a graph convolution per step, then a temporal convolution)
embeds the history; the time-extrapolator (TXP-CNN: convolutions that read the observed
steps as channels and write the future ones) turns it into a bivariate Gaussian of every
future step's displacement (``StepGaussians``), trained by its negative log-likelihood.

Where this differs from the paper's code, and why:

- the graph is the forecast person's neighbourhood at ``t``, not everyone present in the
  whole 20-step window (which reads who is there in the future), and only the forecast
  person's future is scored in the loss (the others' are not in the batch);
- the extrapolator's kernels span the feature axis only, never neighbouring node indices (a
  kernel across nodes mixes people by their arbitrary order in the data);
- no batch normalisation (the graphs are padded to the batch's largest; padding would enter
  the statistics), the spreads through softplus rather than exp, the correlation bounded;
- Adam at the trainer's settings rather than SGD for 250 epochs.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from grouptron.baselines.step_gaussians import RAW_VALUES, StepGaussianForecaster, StepGaussians
from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch, GroupBatch
from grouptron.model.forecaster import model_settings

NEAREST_M = 0.1
"""Distances below this count as this in the edge kernel (two people at one point would
weigh infinitely)."""


@dataclass(frozen=True)
class SocialSTGCNNSettings:
    """``--set model_settings.NAME=VALUE``, stored with the weights.

    Attributes:
        embedding: channels of the graph convolution's output (the paper's 5).
        extrapolator_layers: TXP-CNN layers (the paper's 5).
        kernel: temporal and extrapolator kernel size (the paper's 3).
        min_sigma_m: the least spread of a step's displacement, metres.
    """

    embedding: int = 5
    extrapolator_layers: int = 5
    kernel: int = 3
    min_sigma_m: float = 0.01


@dataclass(frozen=True)
class NodeGraphs:
    """A batch's graphs padded to its largest: ``N`` node slots per sample, the forecast
    person in slot 0.

    Attributes:
        displacement_m: (B, T, N, 2) each node's displacement over each history step.
        adjacency: (B, T, N, N) each step's normalised edge weights (self-loops included).
    """

    displacement_m: torch.Tensor
    adjacency: torch.Tensor


def node_graphs(batch: Batch, config: ExperimentConfig) -> NodeGraphs:
    """The graphs of ``batch``'s samples from its node states (``Batch.groups``)."""
    nodes: GroupBatch | None = batch.groups
    if nodes is None:
        raise GrouptronError("social-stgcnn reads each sample's neighbours: a batch without them")
    data = config.data
    node_sample = nodes.group_sample[nodes.node_group]  # (Nn,) nodes of a sample are adjacent
    counts = torch.bincount(node_sample, minlength=len(batch))  # (B,)
    first = torch.cumsum(counts, 0) - counts
    slot = torch.arange(len(node_sample), device=counts.device) - first[node_sample]
    T, width = nodes.node_st.shape[1], int(counts.max())
    # A node's state is relative to the ego's at t: add the ego's velocity back for its own.
    ego_velocity_st = batch.hist_st[:, -1, 2:4]  # (B, 2)
    velocity_mps = (nodes.node_st[..., 2:4] + ego_velocity_st[node_sample, None]) * (
        data.velocity_scale_mps
    )
    observed = nodes.node_mask  # (Nn, T)
    step_m = velocity_mps * data.dt_s * observed[..., None]
    position_m = nodes.node_st[..., :2] * data.position_scale_m
    dtype = batch.hist_st.dtype
    displacement = torch.zeros(len(batch), width, T, 2, dtype=dtype, device=counts.device)
    positions = torch.zeros_like(displacement)
    present = torch.zeros(len(batch), width, T, dtype=torch.bool, device=counts.device)
    displacement[node_sample, slot] = step_m.to(dtype)
    positions[node_sample, slot] = position_m.to(dtype)
    present[node_sample, slot] = observed
    positions, present = positions.transpose(1, 2), present.transpose(1, 2)  # (B, T, N, ...)
    distance = torch.cdist(positions, positions).clamp_min(NEAREST_M)  # (B, T, N, N)
    both = present[..., :, None] & present[..., None, :]
    weights = torch.where(both, 1.0 / distance, torch.zeros_like(distance))
    eye = torch.eye(width, dtype=dtype, device=counts.device)
    weights = weights * (1 - eye) + eye  # self-loops, also for slots not observed
    scale = weights.sum(dim=-1).rsqrt()  # (B, T, N): D^-1/2
    adjacency = scale[..., :, None] * weights * scale[..., None, :]
    return NodeGraphs(displacement.transpose(1, 2), adjacency)


class _SpatioTemporalLayer(nn.Module):
    """A graph convolution at every step, then a temporal convolution, with a residual."""

    def __init__(self, inputs: int, outputs: int, kernel: int) -> None:
        super().__init__()
        self.graph = nn.Linear(inputs, outputs)
        self.temporal = nn.Conv2d(outputs, outputs, (kernel, 1), padding=(kernel // 2, 0))
        self.residual = nn.Linear(inputs, outputs)
        self.act_graph, self.act_out = nn.PReLU(), nn.PReLU()

    def forward(self, x: torch.Tensor, adjacency: torch.Tensor) -> torch.Tensor:
        """(B, T, N, C_in), (B, T, N, N) -> (B, T, N, C_out)."""
        mixed = self.graph(torch.einsum("btij,btjc->btic", adjacency, x))
        temporal = self.temporal(self.act_graph(mixed).permute(0, 3, 1, 2)).permute(0, 2, 3, 1)
        out: torch.Tensor = self.act_out(temporal + self.residual(x))
        return out


class _TimeExtrapolator(nn.Module):
    """TXP-CNN: the observed steps as channels, convolved along the features into the
    future steps, with residual layers."""

    def __init__(self, history: int, horizon: int, layers: int, kernel: int) -> None:
        super().__init__()
        pad = (kernel // 2, 0)
        self.first = nn.Conv2d(history, horizon, (kernel, 1), padding=pad)
        self.hidden = nn.ModuleList(
            nn.Conv2d(horizon, horizon, (kernel, 1), padding=pad) for _ in range(layers - 1)
        )
        self.acts = nn.ModuleList(nn.PReLU() for _ in range(layers))
        self.out = nn.Conv2d(horizon, horizon, (kernel, 1), padding=pad)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, C, N) -> (B, H, C, N)."""
        x = self.acts[0](self.first(x))
        for conv, act in zip(self.hidden, self.acts[1:], strict=True):
            x = act(conv(x)) + x
        out: torch.Tensor = self.out(x)
        return out


class SocialSTGCNN(StepGaussianForecaster):
    """The graph of a person's neighbourhood -> a Gaussian of each future displacement."""

    reads_groups = True  # batches then carry every sample's neighbours as nodes

    def __init__(self, config: ExperimentConfig) -> None:
        super().__init__()
        self.settings = model_settings(SocialSTGCNNSettings, config)
        self.config = config
        s, data = self.settings, config.data
        self.embed = _SpatioTemporalLayer(2, s.embedding, s.kernel)
        self.extrapolate = _TimeExtrapolator(
            data.history_steps, data.horizon_steps, s.extrapolator_layers, s.kernel
        )
        self.head = nn.Linear(s.embedding, RAW_VALUES)

    def step_gaussians(self, batch: Batch) -> StepGaussians:
        """The forecast person's (B, H) step Gaussians."""
        graphs = node_graphs(batch, self.config)
        embedded = self.embed(graphs.displacement_m.float(), graphs.adjacency.float())
        future = self.extrapolate(embedded[:, :, :1].transpose(2, 3))  # (B, H, C, 1): slot 0
        raw = self.head(future[..., 0])  # (B, H, 5)
        return StepGaussians.from_raw(raw, self.settings.min_sigma_m)
