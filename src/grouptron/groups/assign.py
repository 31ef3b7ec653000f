"""Groups of every sample: the ego and its neighbours at t, clustered on their histories.

Samples with the same node count are stacked: their distances are computed and their nodes
clustered in one vectorised pass.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from grouptron.config import GroupConfig
from grouptron.constants import DT_S
from grouptron.data.prepare.samples import SampleSet, edge_rows, ego_first_layout
from grouptron.groups.clustering import agglomerative_groups_batched, cluster_counts
from grouptron.groups.distances import group_distances

MAX_DISTANCE_ELEMENTS = 4_000_000
"""Bound on (samples x N x N x T x T) per vectorised distance block (memory)."""


@dataclass(frozen=True)
class SampleGroups:
    """Group labels of every sample's nodes (ego first, then its neighbours in CSR order).

    Attributes:
        ego_group: (S,) the ego's group, in ``0..num_groups-1``.
        nbr_group: (E,) each neighbour's group (aligned with ``SampleSet.nbr_track``).
        num_groups: (S,) C(N) for N = 1 + number of neighbours.
    """

    ego_group: np.ndarray
    nbr_group: np.ndarray
    num_groups: np.ndarray

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The fields as a flat dict of arrays (for ``np.savez``)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> SampleGroups:
        """The groups from :meth:`to_arrays`'s dict (e.g. ``np.load`` of its ``np.savez``)."""
        return cls(**{f.name: arrays[f.name] for f in dataclasses.fields(cls)})

    def subset(self, keep: np.ndarray, samples: SampleSet) -> SampleGroups:
        """The groups of ``samples.subset(keep)``, aligned with it."""
        index = np.flatnonzero(keep)
        edges, _ = edge_rows(samples.nbr_offsets, index)
        return SampleGroups(self.ego_group[index], self.nbr_group[edges], self.num_groups[index])

    @classmethod
    def concatenate(cls, parts: list[SampleGroups]) -> SampleGroups:
        """The groups of ``concatenate_samples`` of the parts' samples, aligned with it."""
        return cls(
            np.concatenate([p.ego_group for p in parts]),
            np.concatenate([p.nbr_group for p in parts]),
            np.concatenate([p.num_groups for p in parts]),
        )


def node_trajectories(
    samples: SampleSet, index: np.ndarray, num_nodes: int, position_scale_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Histories of the ego and its neighbours for samples that all have ``num_nodes`` nodes.

    Returns:
        (S, N, T, 2) positions in metres relative to the ego at ``t`` and (S, N, T) masks.
    """
    edges = samples.nbr_offsets[index][:, None] + np.arange(num_nodes - 1)  # (S, N-1)
    nbr_pos = samples.nbr_hist_st[edges, :, :2] * position_scale_m  # (S, N-1, T, 2)
    traj = np.concatenate([samples.hist_rel_m[index][:, None], nbr_pos], axis=1)
    mask = np.concatenate([samples.hist_mask[index][:, None], samples.nbr_hist_mask[edges]], 1)
    return traj.astype(np.float64), mask


def assign_groups(samples: SampleSet, config: GroupConfig, position_scale_m: float) -> SampleGroups:
    """Cluster every sample's nodes on Hausdorff distances of their histories: into C(N)
    groups, or by ``config.max_distance_m``."""
    node_labels = np.zeros(len(samples) + int(samples.nbr_offsets[-1]), dtype=np.int16)
    node_start, is_ego = ego_first_layout(samples.num_neighbours)
    counts = samples.num_neighbours + 1
    for num_nodes in np.unique(counts):  # one vectorised block per node count
        same = np.flatnonzero(counts == num_nodes)
        if num_nodes == 1 or (num_nodes == 2 and config.max_distance_m is None):
            continue  # C(1) = C(2) = 1: everyone in group 0
        T = samples.hist_st.shape[1]
        block = max(1, MAX_DISTANCE_ELEMENTS // (num_nodes * num_nodes * T * T))
        for start in range(0, len(same), block):
            index = same[start : start + block]
            traj, mask = node_trajectories(samples, index, int(num_nodes), position_scale_m)
            distances = group_distances(
                traj,
                mask,
                kind=config.distance,
                quantile=config.quantile,
                velocity_weight_s=config.velocity_weight_s,
                dt_s=DT_S,
            )
            labels = agglomerative_groups_batched(
                distances,
                config.linkage,
                max_distance=config.max_distance_m,
                max_size=config.max_group_size,
            )  # (S, N)
            rows = node_start[index][:, None] + np.arange(num_nodes)  # (S, N)
            node_labels[rows] = labels
    return _sample_groups(node_labels, node_start, is_ego, counts, config)


def assign_groups_at_step(
    samples: SampleSet, tracks: np.ndarray, distances: np.ndarray, config: GroupConfig
) -> SampleGroups:
    """:func:`assign_groups` for samples that all sit at one step, given that step's (N, N)
    distances between the N ``tracks`` present (``groups.scene.groups_at_step``): each sample's
    matrix is a sub-matrix of it, so no distance is computed twice (live forecasting). The
    partitions equal :func:`assign_groups`' (Hausdorff distances do not depend on the frame
    the positions are given in; a test checks)."""
    counts = samples.num_neighbours + 1
    if not len(samples):
        empty = np.zeros(0, dtype=np.int16)
        return SampleGroups(ego_group=empty, nbr_group=empty, num_groups=empty)
    node_start, is_ego = ego_first_layout(samples.num_neighbours)
    node_track = np.empty(len(is_ego), dtype=np.int64)
    node_track[is_ego], node_track[~is_ego] = samples.track, samples.nbr_track
    slot = np.full(int(max(node_track.max(initial=0), tracks.max(initial=0))) + 1, -1)
    slot[tracks] = np.arange(len(tracks))
    node_slot = slot[node_track]  # (nodes,) row of every node in ``distances``
    if (node_slot < 0).any():
        raise ValueError("a node is not among the step's tracks")
    # All samples in one padded stack (few, small matrices: one pass per merge beats one
    # pass per node count); padding is at infinite distance, so it is never merged.
    width = int(counts.max())
    slots = np.arange(width)
    real = slots < counts[:, None]  # (S, W)
    index = np.where(
        real, node_slot[np.minimum(node_start[:, None] + slots, len(node_slot) - 1)], 0
    )
    block = distances[index[:, :, None], index[:, None, :]]  # (S, W, W)
    block[~(real[:, :, None] & real[:, None, :])] = np.inf
    labels = agglomerative_groups_batched(
        block,
        config.linkage,
        num_nodes=counts,
        max_distance=config.max_distance_m,
        max_size=config.max_group_size,
    )  # (S, W)
    node_labels = labels[real].astype(np.int16)  # row-major: sample by sample, ego first
    return _sample_groups(node_labels, node_start, is_ego, counts, config)


def _sample_groups(
    node_labels: np.ndarray,
    node_start: np.ndarray,
    is_ego: np.ndarray,
    counts: np.ndarray,
    config: GroupConfig,
) -> SampleGroups:
    """Per-sample groups from the flat node labels (ego first in every sample's block)."""
    if config.max_distance_m is None:
        num_groups = cluster_counts(counts)  # C(N), what the clustering was asked for
    else:  # as many as the cut left: one more than the highest label of each sample
        num_groups = np.maximum.reduceat(node_labels, node_start) + 1 if len(counts) else counts
    return SampleGroups(
        ego_group=node_labels[is_ego],
        nbr_group=node_labels[~is_ego],
        num_groups=num_groups.astype(np.int16),
    )
