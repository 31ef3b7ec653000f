"""Groups at a step from near pairs only: the same groups, the same distances within the
threshold, and the same groups of every person's own neighbourhood, as the all-pairs
clustering."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.scene import build_scene
from grouptron.groups import scene as groups_scene
from grouptron.groups.clustering import agglomerative_groups, canonical_labels, linked_pieces
from grouptron.groups.distances import (
    group_distances,
    near_pairs,
    pairwise_distances,
    sparse_pair_distances,
)

RULE = GroupConfig(linkage="single", max_distance_m=1.5, velocity_weight_s=2.0)


def _crowd(people: int = 150, steps: int = 14, seed: int = 3) -> np.ndarray:
    """(R, 4) frame, id, x, y of a dense crowd: pairs walking side by side (a person and the
    next start 0.6 m apart with one velocity), a fifth standing, each present for a span of
    its own, about one person per 2 m^2."""
    rng = np.random.default_rng(seed)
    side = np.sqrt(2.0 * people)
    rows = []
    for pair in range(people // 2):
        start = rng.uniform(0, side, 2)
        velocity = rng.normal(0, 1.0, 2) * (rng.uniform() > 0.2)
        first, last = sorted(rng.integers(0, steps, 2))
        for member in range(2):
            for step in range(first, last + 1):
                xy = start + [0.6 * member, 0.0] + velocity * 0.4 * step + rng.normal(0, 0.05, 2)
                rows.append([step * 10, 2 * pair + member, *xy])
    return np.asarray(rows)


def test_near_groups_equal_all_pairs_groups_at_every_step() -> None:
    values = _crowd()
    table = table_from_values(Path("crowd"), values, np.arange(len(values)), 10)
    scene = build_scene(table, DataConfig(derivatives="backward"), name="crowd")
    pos, present = groups_scene.position_grid(scene, 7)
    compared = 0
    for step in range(scene.num_steps):
        old = groups_scene._cluster_step(pos, present, step, 7, config=RULE, dt_s=0.4)
        new = groups_scene.groups_at_step(scene, RULE, step)
        if old is None:
            assert new is None
            continue
        assert new is not None and np.array_equal(old.labels, new.labels)
        within = old.distances <= RULE.max_distance_m
        assert np.array_equal(old.distances[within], new.distances[within])
        assert (new.distances[~within] > RULE.max_distance_m).all()
        near = np.linalg.norm(old.pos_now_m[:, None] - old.pos_now_m[None], axis=-1) <= 3.0
        for ego in range(len(old.tracks)):  # each person's own grouping, as the model's
            nodes = np.flatnonzero(near[ego])
            nodes = np.concatenate([[ego], nodes[nodes != ego]])
            mine = [
                agglomerative_groups(d[np.ix_(nodes, nodes)], "single", max_distance=1.5)
                for d in (old.distances, new.distances)
            ]
            assert np.array_equal(*mine)
        compared += len(old.tracks) > 30 and len(np.unique(old.labels)) < len(old.labels)
    assert compared >= 5  # crowded steps with real groups


def test_no_pair_left_out_could_be_within_the_threshold() -> None:
    rng = np.random.default_rng(0)
    traj = rng.uniform(0, 8, (60, 1, 2)) + np.cumsum(rng.normal(0, 0.5, (60, 8, 2)), axis=1)
    mask = rng.uniform(size=(60, 8)) > 0.2
    mask[:, -1] = True
    pairs = {tuple(p) for p in near_pairs(traj, mask, traj[:, -1], 1.5)}
    full = pairwise_distances(traj, mask)
    close = np.argwhere(np.triu(full <= 1.5, k=1))
    assert len(close) and all(tuple(p) in pairs for p in close)


def test_pairs_dropped_for_their_velocities_could_never_be_within_the_threshold() -> None:
    rng = np.random.default_rng(1)
    traj = rng.uniform(0, 6, (60, 1, 2)) + np.cumsum(rng.normal(0, 0.4, (60, 8, 2)), axis=1)
    mask = np.ones((60, 8), bool)
    pairs, distance = sparse_pair_distances(
        traj, mask, traj[:, -1], within_m=1.5, velocity_weight_s=2.0, dt_s=0.4
    )
    full = group_distances(
        traj, mask, kind="hausdorff", quantile=0.9, velocity_weight_s=2.0, dt_s=0.4
    )
    close = np.argwhere(np.triu(full <= 1.5, k=1))
    found = dict(zip(map(tuple, pairs), distance, strict=True))
    assert len(close) and all(np.isclose(found[tuple(p)], full[tuple(p)]) for p in close)
    assert len(pairs) < len(near_pairs(traj, mask, traj[:, -1], 1.5))  # some were dropped


def test_linked_pieces_are_the_connected_components() -> None:
    rng = np.random.default_rng(2)
    for trial in range(60):
        n = int(rng.integers(1, 120))
        linked = rng.integers(0, n, (int(rng.integers(0, 2 * n)), 2))
        if trial % 3 == 0:  # a chain through everyone, in a random order
            order = rng.permutation(n)
            linked = np.stack([order[:-1], order[1:]], axis=1)
        graph = csr_matrix((np.ones(len(linked)), (linked[:, 0], linked[:, 1])), shape=(n, n))
        expected = connected_components(graph, directed=False)[1]
        assert np.array_equal(
            canonical_labels(linked_pieces(n, linked)), canonical_labels(expected)
        )
