"""Grouptron: the Trajectron++ CVAE with group-level and scene-level ST-GCN encoders.

x = [edge encoding; history encoding; E_scene], where
  E_g     = mean over the members of group g of the group-level ST-GCN's node embeddings,
  E_scene = the scene-level ST-GCN (over the sample's groups, states E_g) at the ego's group
            and the last history step (paper section III-C).
"""

from __future__ import annotations

import torch
from torch import nn

from grouptron.config import GroupEncoderConfig, ModelConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.noise import TrainingNoise
from grouptron.model.stgcn import STGCNBlock, segment_mean


class GrouptronCVAE(TrajectronCVAE):
    """Trajectron++ plus the group- and scene-level encoders (weights shared by all groups)."""

    reads_groups = True

    def __init__(
        self, config: ModelConfig, groups: GroupEncoderConfig, velocity_scale_mps: float = 2.0
    ):
        counted = 1 if groups.count_feature else 0  # log(1 + count) channels
        super().__init__(config, groups.group_dim + counted, velocity_scale_mps)
        self.groups_config = groups
        width, adjacency, layers = groups.group_dim, groups.group_adjacency, groups.temporal_layers
        self.group_encoder = STGCNBlock(config.state_dim, width, adjacency, temporal_layers=layers)
        self.scene_encoder = STGCNBlock(width + counted, width, adjacency, temporal_layers=layers)
        self.scene_norm = nn.LayerNorm(width) if groups.scene_layer_norm else None

    @property
    def ablations(self) -> tuple[str, ...]:
        """Trajectron++'s and ``scene``, its scene encoding E_scene."""
        return (*super().ablations, "scene")

    def extra_dropout_sizes(self) -> dict[str, int]:
        """The ``scene`` dropout site (E_scene's features) where ``scene_dropout_keep`` is below
        1; none otherwise."""
        keep = self.groups_config.scene_dropout_keep
        return {"scene": self.condition_dim - self.base_condition_dim} if keep < 1.0 else {}

    def encode_scene(self, batch: Batch, drawn: TrainingNoise | None = None) -> torch.Tensor:
        """(B, group_dim) E_scene of every sample (+ 1 with the count feature)."""
        groups, variant = batch.groups, self.groups_config
        if groups is None:
            raise GrouptronError("Grouptron needs batches with groups (make_batch(groups=...))")
        nodes = self.group_encoder(
            groups.node_st, groups.node_mask, groups.node_group, groups.num_groups
        )  # (Nn, T, D)
        members = groups.node_mask
        if not variant.ego_in_own_group:  # nodes are laid out ego first in every sample
            node_sample = groups.group_sample[groups.node_group]  # (Nn,)
            is_ego = torch.ones_like(node_sample, dtype=torch.bool)
            is_ego[1:] = node_sample[1:] != node_sample[:-1]
            members = members & ~is_ego[:, None]
        group_state, _ = segment_mean(nodes, members, groups.node_group, groups.num_groups)
        # A group exists where any member (the ego included) does, even when its state
        # leaves the ego out: a lone ego's group then has a zero state, not no node.
        _, group_mask = segment_mean(nodes, groups.node_mask, groups.node_group, groups.num_groups)
        B = batch.hist_st.shape[0]  # a tensor size, not len(): export keeps it symbolic
        if variant.count_feature:
            count = groups.node_mask.new_zeros(
                groups.num_groups, members.shape[1], dtype=nodes.dtype
            )
            count.index_add_(0, groups.node_group, groups.node_mask.to(nodes.dtype))  # (G, T)
            group_state = torch.cat([group_state, torch.log1p(count)[..., None]], dim=-1)
        scene = self.scene_encoder(group_state, group_mask, groups.group_sample, B)  # (G, T, D)
        encoding = scene[groups.ego_group, -1]  # (B, D)
        if self.scene_norm is not None:
            encoding = self.scene_norm(encoding)
        if variant.count_feature:
            num_groups = nodes.new_zeros(B).index_add_(
                0, groups.group_sample, torch.ones_like(groups.group_sample, dtype=nodes.dtype)
            )
            encoding = torch.cat([encoding, torch.log1p(num_groups)[:, None]], dim=-1)
        return self._dropout(encoding, drawn, "scene", variant.scene_dropout_keep)

    def encode_condition(self, batch: Batch, drawn: TrainingNoise | None = None) -> torch.Tensor:
        """(B, Dx) ``x = [edge encoding; history encoding; E_scene]``; ``drawn`` as for the CVAE."""
        base = super().encode_condition(batch, drawn)
        return torch.cat([base, self.encode_scene(batch, drawn)], -1)
