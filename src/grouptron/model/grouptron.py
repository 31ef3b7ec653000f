"""Grouptron: the Trajectron++ CVAE with group-level and scene-level ST-GCN encoders.

x = [edge encoding; history encoding; E_scene], where
  E_g     = mean over the members of group g of the group-level ST-GCN's node embeddings,
  E_scene = the scene-level ST-GCN (over the sample's groups, states E_g) at the ego's group
            and the last history step (paper section III-C).
"""

from __future__ import annotations

import torch

from grouptron.config import GroupEncoderConfig, ModelConfig
from grouptron.errors import GrouptronError
from grouptron.model.batch import Batch
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.noise import TrainingNoise
from grouptron.model.stgcn import STGCNBlock, segment_mean


class GrouptronCVAE(TrajectronCVAE):
    """Trajectron++ plus the group- and scene-level encoders (weights shared by all groups)."""

    def __init__(self, config: ModelConfig, groups: GroupEncoderConfig):
        super().__init__(config, extra_condition_dim=groups.group_dim)
        width, adjacency = groups.group_dim, groups.group_adjacency
        self.group_encoder = STGCNBlock(config.state_dim, width, adjacency)
        self.scene_encoder = STGCNBlock(width, width, adjacency)

    def encode_scene(self, batch: Batch) -> torch.Tensor:
        """(B, group_dim) E_scene of every sample."""
        groups = batch.groups
        if groups is None:
            raise GrouptronError("Grouptron needs batches with groups (make_batch(groups=...))")
        nodes = self.group_encoder(
            groups.node_st, groups.node_mask, groups.node_group, groups.num_groups
        )  # (Nn, T, D)
        group_state, group_mask = segment_mean(
            nodes, groups.node_mask, groups.node_group, groups.num_groups
        )  # (G, T, D), (G, T)
        # The sample count as a tensor size, not len(): export keeps it symbolic that way.
        scene = self.scene_encoder(
            group_state, group_mask, groups.group_sample, batch.hist_st.shape[0]
        )  # (G, T, D)
        return scene[groups.ego_group, -1]

    def encode_condition(self, batch: Batch, drawn: TrainingNoise | None = None) -> torch.Tensor:
        return torch.cat([super().encode_condition(batch, drawn), self.encode_scene(batch)], -1)
