"""Groups of a whole recording, step by step, and their agreement with human labels."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, GroupConfig
from grouptron.constants import HISTORY_STEPS, PERCEPTION_RADIUS_M
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.samples import dense_grid
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.groups.clustering import agglomerative_groups, canonical_labels, linked_pieces
from grouptron.groups.distances import group_distances, pair_matrix, sparse_pair_distances
from grouptron.groups.labels import (
    PairCounts,
    dice_of_partitions,
    partition_from_labels,
    read_group_labels,
    same_group_pairs,
)
from grouptron.groups.learned import (
    PairClassifier,
    learned_distances,
    linked_groups,
    load_classifier,
    near_pairs_now,
)
from grouptron.groups.pair_features import FEATURES, pair_features
from grouptron.groups.pair_memory import MEMORY_WEIGHT, PairMemory
from grouptron.groups.partition_scores import PartitionCounts


@dataclass(frozen=True)
class StepGroups:
    """The scene-wide groups of one step.

    Attributes:
        step: the step.
        tracks: (N,) tracks present at the step.
        labels: (N,) their groups (C(N) of them under the paper's rule).
        distances: (N, N) Hausdorff distances of their histories.
        pos_now_m: (N, 2) positions at the step (scene frame).
    """

    step: int
    tracks: np.ndarray
    labels: np.ndarray
    distances: np.ndarray
    pos_now_m: np.ndarray


@dataclass(frozen=True)
class _Learned:
    """A learned detector at work on a recording: its classifier, and its memory of pairs
    keyed by the (A,) ids of the recording's tracks (None: none)."""

    classifier: PairClassifier
    memory: PairMemory | None = None
    ids: np.ndarray | None = None


def position_grid(scene: Scene, pad_before: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, pad_before + num_steps, 2) positions and presence, left-padded for windows."""
    state, present = dense_grid(scene, pad_before, 0)
    return state[..., :2], present


def groups_per_step(
    scene: Scene,
    config: GroupConfig,
    history_steps: int = HISTORY_STEPS,
    every: int = 1,
    classifier: PairClassifier | None = None,
    memory_weight: float | None = MEMORY_WEIGHT,
) -> Iterator[StepGroups]:
    """Cluster the pedestrians present at each step on their last ``history_steps`` positions
    (a learned detector's ``classifier``: None, the shipped one; it remembers each pair from
    step to step, ``pair_memory``, with ``memory_weight`` on the newest step; None: no
    memory)."""
    pad = history_steps - 1
    pos, present = position_grid(scene, pad)
    learned = None
    if config.detector == "learned":
        memory = None if memory_weight is None else PairMemory(memory_weight)
        learned = _Learned(classifier or load_classifier(), memory, scene.ped_id)
    for step in range(0, scene.num_steps, every):  # one clustering per step
        found = _cluster_step(
            pos,
            present,
            step,
            pad,
            config=config,
            dt_s=scene.dt_s,
            learned=learned,
        )
        if found is not None:
            yield found


def groups_at_step(
    scene: Scene,
    config: GroupConfig,
    step: int,
    history_steps: int = HISTORY_STEPS,
    memory: PairMemory | None = None,
) -> StepGroups | None:
    """The scene-wide groups of one step (None when nobody is present); a learned rule's with
    its ``memory`` of the steps before, where given (fed in order). Under a distance
    threshold with single linkage and no size cap (the detection rule and the default
    model's), the groups are the connected pieces of the pairs within the threshold, and only
    pairs that could be within the threshold are measured (a k-d tree, their mean velocities,
    then a bound per pair):
    the groups equal the all-pairs clustering's (a test checks), and ``distances`` hold every
    pair within the threshold exactly and infinity for most others, so that each person's own
    grouping (the same rule on a sub-matrix) decides as with all pairs."""
    pad = history_steps - 1
    pos, present = position_grid(scene, pad)
    learned = None
    if config.detector == "learned":
        learned = _Learned(load_classifier(), memory, scene.ped_id)
    return _cluster_step(
        pos, present, step, pad, config=config, dt_s=scene.dt_s, near_only=True, learned=learned
    )


def _connected_pieces_suffice(config: GroupConfig) -> bool:
    """Whether the rule's groups are the connected pieces of the pairs within its threshold:
    single linkage, a threshold, no size cap, the Hausdorff distance."""
    return (
        config.linkage == "single"
        and config.max_distance_m is not None
        and config.max_group_size is None
        and config.distance == "hausdorff"
    )


def _cluster_step(
    pos: np.ndarray,
    present: np.ndarray,
    step: int,
    pad: int,
    *,
    config: GroupConfig,
    dt_s: float,
    near_only: bool = False,
    learned: _Learned | None = None,
) -> StepGroups | None:
    """The groups of the people present at ``step``; with ``near_only``, where the rule's
    groups are its threshold's connected pieces, from near pairs only (``groups_at_step``);
    a learned rule's by the ``learned`` detector (the shipped one, without memory, where none
    is given)."""
    tracks = np.flatnonzero(present[:, step + pad])
    if len(tracks) == 0:
        if learned is not None and learned.memory is not None:
            learned.memory.forget()
        return None
    window = slice(step, step + pad + 1)
    traj, mask, now = pos[tracks, window], present[tracks, window], pos[tracks, step + pad]
    if config.detector == "learned":
        assert config.max_distance_m is not None
        learned = learned or _Learned(load_classifier())
        track_ids = None if learned.ids is None else learned.ids[tracks]
        distances = learned_distances(
            traj, mask, dt_s, learned.classifier, learned.memory, track_ids
        )
        labels = linked_groups(distances, config.max_distance_m, config.max_group_size)
        return StepGroups(step, tracks, labels, distances, now)
    if near_only and _connected_pieces_suffice(config):
        assert config.max_distance_m is not None
        pairs, distance = sparse_pair_distances(
            traj,
            mask,
            now,
            within_m=config.max_distance_m,
            velocity_weight_s=config.velocity_weight_s,
            dt_s=dt_s,
        )
        labels = canonical_labels(
            linked_pieces(len(tracks), pairs[distance <= config.max_distance_m])
        )
        return StepGroups(step, tracks, labels, pair_matrix(len(tracks), pairs, distance), now)
    distances = group_distances(
        traj,
        mask,
        kind=config.distance,
        quantile=config.quantile,
        velocity_weight_s=config.velocity_weight_s,
        dt_s=dt_s,
    )
    labels = agglomerative_groups(
        distances,
        config.linkage,
        max_distance=config.max_distance_m,
        max_size=config.max_group_size,
    )
    return StepGroups(step, tracks, labels, distances, now)


def score_against_labels(
    scene: Scene,
    labels: dict[int, int],
    config: GroupConfig,
    radius_m: float = PERCEPTION_RADIUS_M,
    *,
    every: int = 1,
    classifier: PairClassifier | None = None,
    memory_weight: float | None = MEMORY_WEIGHT,
) -> dict[str, dict[str, float]]:
    """Pairwise precision/recall/F1 and Dice of detected against labelled groups, and in the
    ``scene`` scope G-MITRE and group matches (``partition_scores``).

    Two scopes, over every step with two or more pedestrians:
      ``scene``: all pedestrians present are clustered together; every pair is a decision.
      ``per_ego``: as the model does, each pedestrian and those within ``radius_m`` of it are
      clustered; the decisions are "is this neighbour in the ego's group".

    Args:
        scene: the recording.
        labels: {pedestrian id: group label} (ids of the scene's file).
        classifier, memory_weight: a learned rule's (:func:`groups_per_step`).
    """
    scene_counts, ego_counts, partitions = PairCounts(), PairCounts(), PartitionCounts()
    steps = groups_per_step(
        scene, config, every=every, classifier=classifier, memory_weight=memory_weight
    )
    for found in steps:
        if len(found.tracks) < 2:
            continue
        truth = partition_from_labels(scene.ped_id[found.tracks], labels)
        scene_counts.add_pairs(same_group_pairs(found.labels), same_group_pairs(truth))
        scene_counts.add_dice(dice_of_partitions(found.labels, truth))
        partitions.add(found.labels, truth)
        near = np.linalg.norm(found.pos_now_m[:, None] - found.pos_now_m[None], axis=-1)
        for ego in range(len(found.tracks)):  # the model's per-ego clustering
            others = np.flatnonzero((near[ego] <= radius_m) & (np.arange(len(near)) != ego))
            if len(others) == 0:
                continue
            nodes = np.concatenate([[ego], others])
            predicted = agglomerative_groups(
                found.distances[np.ix_(nodes, nodes)],
                config.linkage,
                max_distance=config.max_distance_m,
                max_size=config.max_group_size,
            )
            labelled = truth[nodes]
            ego_counts.add_pairs(predicted[1:] == predicted[0], labelled[1:] == labelled[0])
            ego_counts.add_dice(dice_of_partitions(predicted, labelled))
    return {
        "scene": {**scene_counts.summary(), **partitions.summary()},
        "per_ego": ego_counts.summary(),
    }


def labelled_pairs(
    scene: Scene, labels: dict[int, int], history_steps: int = HISTORY_STEPS, every: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Training data of a pair classifier: (P, F) the features of every pair within
    ``learned.GATE_M`` of each other at every ``every``-th step of a recording, (P,) whether
    the labels put them in one group and (P,) the step."""
    pad = history_steps - 1
    pos, present = position_grid(scene, pad)
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for step in range(0, scene.num_steps, every):  # one batch of pairs per step
        tracks = np.flatnonzero(present[:, step + pad])
        window = slice(step, step + pad + 1)
        pairs = near_pairs_now(pos[tracks, step + pad])
        if not len(pairs):
            continue
        truth = partition_from_labels(scene.ped_id[tracks], labels)
        features = pair_features(pos[tracks, window], present[tracks, window], pairs, scene.dt_s)
        together = truth[pairs[:, 0]] == truth[pairs[:, 1]]
        parts.append((features, together, np.full(len(pairs), step)))
    if not parts:
        return np.zeros((0, len(FEATURES)), np.float32), np.zeros(0, bool), np.zeros(0, int)
    features, together, steps = (np.concatenate(part) for part in zip(*parts, strict=True))
    return features, together, steps


LABELLED_RECORDINGS = {"eth": "biwi_eth", "hotel": "biwi_hotel", "zara1": "crowds_zara01",
                       "zara2": "crowds_zara02"}  # fmt: skip
"""The ETH/UCY recordings with human group labels: their label folder's name, then their file
in the benchmark's ``all_data/``."""


def labelled_recordings(
    labels_dir: str | Path, data_dir: Path
) -> tuple[dict[str, Scene], dict[str, dict[int, int]]]:
    """The scenes of :data:`LABELLED_RECORDINGS` (``data_dir/all_data``) and their labels
    (``labels_dir/<name>/groups.txt``), by name."""
    scenes = {name: build_scene(read_tracks(data_dir / "all_data" / f"{file}.txt"), DataConfig())
              for name, file in LABELLED_RECORDINGS.items()}  # fmt: skip
    labels = {name: read_group_labels(Path(labels_dir) / name / "groups.txt")
              for name in LABELLED_RECORDINGS}  # fmt: skip
    return scenes, labels
