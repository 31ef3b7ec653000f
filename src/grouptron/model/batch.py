"""The typed batch the model consumes, gathered from a :class:`SampleSet` by index."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import torch

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.data.prepare.samples import SampleSet, edge_rows, ego_first_layout, segment_sums
from grouptron.geometry import rotate_rows, rotation_matrix
from grouptron.groups.assign import SampleGroups


@dataclass(frozen=True)
class GroupBatch:
    """The nodes of every sample (ego first, then its neighbours), flat, with their groups.

    Attributes:
        node_st: (Nn, T, 6) node states relative to the ego's state at ``t``, standardised.
        node_mask: (Nn, T) True where the node was observed.
        node_group: (Nn,) group of every node, numbered across the batch.
        group_sample: (G,) sample of every group.
        ego_group: (B,) the group holding each sample's ego.
    """

    node_st: torch.Tensor
    node_mask: torch.Tensor
    node_group: torch.Tensor
    group_sample: torch.Tensor
    ego_group: torch.Tensor

    @property
    def num_groups(self) -> int:
        """Number of groups in the batch (G)."""
        return self.group_sample.shape[0]

    def to(self, device: torch.device | str) -> GroupBatch:
        """A copy with every tensor on ``device``."""
        return GroupBatch(**{f.name: getattr(self, f.name).to(device) for f in fields(self)})


def make_group_batch(
    samples: SampleSet,
    groups: SampleGroups,
    index: np.ndarray,
    hist_st: np.ndarray,
    *,
    rotation: np.ndarray | None,
    edges: np.ndarray,
    counts: np.ndarray,
) -> GroupBatch:
    """Flatten the nodes and groups of samples ``index`` (``hist_st`` already gathered and,
    with ``rotation`` (B, 2, 2), rotated; ``edges`` (E_b,) and ``counts`` (B,) their edge rows
    from ``edge_rows``)."""
    nbr_st = samples.nbr_hist_st[edges]
    if rotation is not None:
        nbr_st = rotate_rows(nbr_st, np.repeat(rotation, counts, axis=0))
    # The ego as a node: its state relative to its own state at t (positions already are).
    ego_st = hist_st.copy()
    ego_st[..., 2:] -= hist_st[:, -1:, 2:]
    ego_st *= samples.hist_mask[index][..., None]
    _, is_ego = ego_first_layout(counts)
    nodes_per_sample, total = counts + 1, len(is_ego)
    node_st = np.empty((total, *hist_st.shape[1:]), dtype=np.float32)
    node_st[is_ego], node_st[~is_ego] = ego_st, nbr_st
    node_mask = np.empty((total, hist_st.shape[1]), dtype=bool)
    node_mask[is_ego], node_mask[~is_ego] = samples.hist_mask[index], samples.nbr_hist_mask[edges]
    local = np.empty(total, dtype=np.int64)
    local[is_ego], local[~is_ego] = groups.ego_group[index], groups.nbr_group[edges]
    num_groups = groups.num_groups[index].astype(np.int64)
    group_start = np.concatenate([[0], np.cumsum(num_groups)[:-1]])
    node_sample = np.repeat(np.arange(len(index)), nodes_per_sample)
    return GroupBatch(
        node_st=torch.from_numpy(node_st),
        node_mask=torch.from_numpy(node_mask),
        node_group=torch.from_numpy(group_start[node_sample] + local),
        group_sample=torch.from_numpy(np.repeat(np.arange(len(index)), num_groups)),
        ego_group=torch.from_numpy(group_start + groups.ego_group[index].astype(np.int64)),
    )


@dataclass(frozen=True)
class Batch:
    """Model inputs and targets of ``B`` samples (``T`` history, ``H`` future steps).

    Attributes:
        hist_st: (B, T, 6) standardised ego history, 0 where masked.
        hist_mask: (B, T) True where the ego was observed; masked steps lead (left padding).
        nbr_sum_st: (B, T, 6) summed standardised neighbour states.
        edge_scale: (B,) ``min(1, sum of edge weights)``, the edge encoding's scale.
        fut_rel_m: (B, H, 2) future positions relative to the current one, metres.
        fut_st: (B, H, 2) the same divided by the future scale (future encoder input).
        groups: the nodes and groups for Grouptron's encoders, or None.
        nbr_count: (B, T) neighbours observed at each history step, 0 where the ego is
            masked (the ``mean`` edge aggregation and the count feature); None for batches
            built by hand for models that read neither.
    """

    hist_st: torch.Tensor
    hist_mask: torch.Tensor
    nbr_sum_st: torch.Tensor
    edge_scale: torch.Tensor
    fut_rel_m: torch.Tensor
    fut_st: torch.Tensor
    groups: GroupBatch | None = None
    nbr_count: torch.Tensor | None = None

    def __len__(self) -> int:
        return self.hist_st.shape[0]

    @property
    def state_now_st(self) -> torch.Tensor:
        """(B, 6) the standardised state at ``t`` (position part is 0)."""
        return self.hist_st[:, -1]

    def to(self, device: torch.device | str) -> Batch:
        """A copy with every tensor (the groups' included) on ``device``."""
        moved: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            moved[f.name] = value.to(device) if value is not None else None
        return Batch(**moved)


def make_batch(
    samples: SampleSet,
    index: np.ndarray,
    config: DataConfig,
    rotation_rad: np.ndarray | None = None,
    *,
    groups: SampleGroups | None = None,
) -> Batch:
    """Gather samples ``index`` into a batch, optionally rotating each sample's scene.

    Args:
        samples: the sample set.
        index: (B,) sample indices.
        config: the data protocol (for the future encoder's scale).
        rotation_rad: (B,) angles; rotating all (x, y) pairs equals rotating the scene.
        groups: the samples' groups, for Grouptron (None for Trajectron++).
    """
    hist_st = samples.hist_st[index]
    nbr_sum_st = samples.nbr_sum_st[index]
    fut_rel_m = samples.fut_rel_m[index]
    rotation = None
    if rotation_rad is not None:
        rotation = rotation_matrix(rotation_rad)  # (B, 2, 2)
        hist_st = rotate_rows(hist_st, rotation)
        nbr_sum_st = rotate_rows(nbr_sum_st, rotation)
        fut_rel_m = rotate_rows(fut_rel_m, rotation)
    fut = torch.from_numpy(np.ascontiguousarray(fut_rel_m))
    edges, counts = edge_rows(samples.nbr_offsets, index)  # (E_b,), (B,)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    nbr_count = segment_sums(samples.nbr_hist_mask[edges], offsets) * samples.hist_mask[index]
    return Batch(
        hist_st=torch.from_numpy(np.ascontiguousarray(hist_st)),
        hist_mask=torch.from_numpy(samples.hist_mask[index]),
        nbr_sum_st=torch.from_numpy(np.ascontiguousarray(nbr_sum_st)),
        edge_scale=torch.from_numpy(np.minimum(samples.edge_weight_sum[index], 1.0)),
        fut_rel_m=fut,
        fut_st=fut / config.future_scale_m,
        groups=(
            make_group_batch(
                samples, groups, index, hist_st, rotation=rotation, edges=edges, counts=counts
            )
            if groups is not None
            else None
        ),
        nbr_count=torch.from_numpy(nbr_count.astype(np.float32)),
    )


def batches(
    samples: SampleSet,
    config: ExperimentConfig,
    batch_size: int,
    groups: SampleGroups | None = None,
) -> Iterator[tuple[np.ndarray, Batch]]:
    """Consecutive batches of the whole set, in order, without augmentation."""
    for start in range(0, len(samples), batch_size):
        index = np.arange(start, min(start + batch_size, len(samples)))
        yield index, make_batch(samples, index, config.data, groups=groups)
