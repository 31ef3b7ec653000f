"""Grouptron's spatio-temporal graph convolutions over groups and over the scene's groups.

Graphs are fully connected inside a segment (the members of a group, or the groups of a sample),
so a graph convolution is a masked mean (or, for the Laplacian, "self minus the others' mean")
over the segment at every step: computed with ``index_add_`` on flat node lists, never with a
Python loop over samples or groups.
"""

from __future__ import annotations

from typing import Literal

import torch
from torch import nn

Adjacency = Literal["sym_norm", "laplacian"]


def segment_graph_conv(
    features: torch.Tensor,
    mask: torch.Tensor,
    segment: torch.Tensor,
    num_segments: int,
    *,
    adjacency: Adjacency,
) -> torch.Tensor:
    """Graph convolution on fully connected segments, per step.

    ``sym_norm``: D^-1/2 (A + I) D^-1/2 with A + I all ones over the n present members, i.e. the
    members' mean. ``laplacian``: Social-STGCNN's I - D^-1/2 A D^-1/2 with A = ones - I, i.e.
    ``x_i - mean of the others``; zero for a member alone (its degree is 0).

    Args:
        features: (N, T, D) node features.
        mask: (N, T) True where the node exists.
        segment: (N,) segment of every node.
        num_segments: S.
        adjacency: which normalisation.

    Returns:
        (N, T, D), zero where masked.
    """
    weights = mask.to(features.dtype)[..., None]  # (N, T, 1)
    total = features.new_zeros(num_segments, *features.shape[1:])  # (S, T, D)
    total.index_add_(0, segment, features * weights)
    count = features.new_zeros(num_segments, features.shape[1], 1)  # (S, T, 1)
    count.index_add_(0, segment, weights)
    seg_total, seg_count = total[segment], count[segment]  # (N, T, D), (N, T, 1)
    if adjacency == "sym_norm":
        out = seg_total / seg_count.clamp_min(1.0)
    elif adjacency == "laplacian":
        others = (seg_count - 1.0).clamp_min(1.0)
        out = features - (seg_total - features) / others
        out = torch.where(seg_count > 1.0, out, torch.zeros_like(out))
    else:
        raise ValueError(f"unknown adjacency {adjacency!r}")
    return out * weights


def segment_mean(
    features: torch.Tensor, mask: torch.Tensor, segment: torch.Tensor, num_segments: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """(S, T, D) masked mean of the nodes of every segment, and (S, T) whether any exists."""
    weights = mask.to(features.dtype)[..., None]
    total = features.new_zeros(num_segments, *features.shape[1:])
    total.index_add_(0, segment, features * weights)
    count = features.new_zeros(num_segments, features.shape[1], 1)
    count.index_add_(0, segment, weights)
    return total / count.clamp_min(1.0), count[..., 0] > 0


def temporal_conv(conv: nn.Conv1d, x: torch.Tensor) -> torch.Tensor:
    """``conv`` (odd kernel, same padding) along the steps of (N, T, D) features, with the
    weights and result of ``conv`` on (N, D, T).

    Each kernel tap's weights multiply every step in one matrix product, (N, T, k out), and
    the output at step t adds tap j's product at step ``t + j dilation - pad``. Several times
    faster than the convolution library for the short sequences and small batches of live
    forecasting, where its per-call set-up dominates; and without the (N, T, k D) copy of
    every step's window that one product per window needs (about 1 ms of the scene encoder's
    5.4 ms at 300 people, ``benchmarks/streaming.py --profile``)."""
    kernel, dilation = conv.kernel_size[0], conv.dilation[0]
    out, pad, T = conv.out_channels, dilation * (kernel // 2), x.shape[1]
    weight = conv.weight.permute(2, 0, 1).reshape(kernel * out, -1)  # (k out, D), tap-major
    taps = nn.functional.linear(x, weight)  # (N, T, k out)
    centre = kernel // 2  # the tap at shift 0
    bias = 0.0 if conv.bias is None else conv.bias.to(taps.dtype)  # bf16 stays bf16
    result = taps[..., centre * out : (centre + 1) * out] + bias  # (N, T, out), a copy
    for j in range(kernel):  # tap j reads step t + shift; padded steps add nothing
        shift = j * dilation - pad
        if j == centre or abs(shift) >= T:
            continue
        tap = taps[..., j * out : (j + 1) * out]
        if shift > 0:
            result[:, : T - shift] += tap[:, shift:]
        else:
            result[:, -shift:] += tap[:, : T + shift]
    return result


class STGCNBlock(nn.Module):
    """Graph convolution, then a temporal convolution (kernel 3), a residual and PReLU.

    As Social-STGCNN's block without batch normalisation (batches here mix groups of every size
    and masked steps, which make batch statistics unreliable).
    """

    def __init__(
        self,
        in_dim: int,
        out_dim: int,
        adjacency: Adjacency,
        kernel: int = 3,
        *,
        temporal_layers: int = 1,
    ):
        super().__init__()
        self.adjacency: Adjacency = adjacency
        self.spatial = nn.Linear(in_dim, out_dim)
        self.spatial_act = nn.PReLU()
        self.temporal = nn.Conv1d(out_dim, out_dim, kernel, padding=kernel // 2)
        # Further temporal convolutions, dilated 2, 4, ...: the receptive field grows to all
        # observed steps (none by default: the paper's block, and its checkpoints, unchanged).
        self.more_temporal = nn.ModuleList(
            nn.Conv1d(out_dim, out_dim, kernel, padding=2**k * (kernel // 2), dilation=2**k)
            for k in range(1, temporal_layers)
        )
        self.more_act = nn.ModuleList(nn.PReLU() for _ in range(1, temporal_layers))
        self.residual = nn.Linear(in_dim, out_dim) if in_dim != out_dim else nn.Identity()
        self.out_act = nn.PReLU()

    def forward(
        self, x: torch.Tensor, mask: torch.Tensor, segment: torch.Tensor, num_segments: int
    ) -> torch.Tensor:
        """(N, T, in) node features -> (N, T, out), zero where masked."""
        spatial = segment_graph_conv(
            self.spatial(x), mask, segment, num_segments, adjacency=self.adjacency
        )
        spatial = self.spatial_act(spatial)
        temporal = temporal_conv(self.temporal, spatial)  # conv over T
        for conv, act in zip(self.more_temporal, self.more_act, strict=True):
            assert isinstance(conv, nn.Conv1d)
            temporal = temporal_conv(conv, act(temporal) * mask[..., None].to(temporal.dtype))
        out: torch.Tensor = self.out_act(temporal + self.residual(x))
        return out * mask[..., None].to(out.dtype)
