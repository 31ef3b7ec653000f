"""Hausdorff distances, C(N), clustering and group labels on hand-made cases."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.cluster.hierarchy import cut_tree, linkage
from scipy.spatial.distance import directed_hausdorff as scipy_directed
from scipy.spatial.distance import squareform

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.prepare.samples import scene_samples
from grouptron.errors import DataFormatError
from grouptron.groups.assign import assign_groups
from grouptron.groups.clustering import (
    agglomerative_groups,
    agglomerative_groups_batched,
    canonical_labels,
    cluster_count,
)
from grouptron.groups.distances import directed_hausdorff, pairwise_distances
from grouptron.groups.labels import (
    dice_of_partitions,
    partition_from_labels,
    read_group_labels,
    read_id_map,
)
from grouptron.presets import DETECTION_GROUPS, describe_group_rule
from tests.helpers.data import walking_scene

LINE = np.stack([np.arange(4.0), np.zeros(4)], -1)  # (0,0) (1,0) (2,0) (3,0)


def test_hausdorff_of_hand_made_trajectories() -> None:
    shifted = LINE + np.array([0.0, 2.0])  # parallel, 2 m away
    short = LINE[:2]  # (0,0) (1,0): inside the line
    traj = np.stack([LINE, shifted, np.concatenate([short, short])])
    mask = np.ones((3, 4), bool)
    mask[2, 2:] = False  # the third trajectory only has its first two points
    directed = directed_hausdorff(traj, mask)
    assert directed[0, 1] == pytest.approx(2.0)
    assert directed[2, 0] == pytest.approx(0.0)  # every point of `short` lies on LINE
    assert directed[0, 2] == pytest.approx(2.0)  # (3,0) is 2 m from (1,0)
    symmetric = pairwise_distances(traj, mask)
    np.testing.assert_allclose(symmetric, symmetric.T)
    np.testing.assert_allclose(np.diag(symmetric), 0.0)
    assert symmetric[0, 2] == pytest.approx(2.0)


def test_hausdorff_matches_scipy_on_random_curves() -> None:
    rng = np.random.default_rng(0)
    traj = rng.normal(size=(5, 8, 2)).cumsum(1)
    directed = directed_hausdorff(traj, np.ones((5, 8), bool))
    for i in range(5):
        for j in range(5):
            assert directed[i, j] == pytest.approx(scipy_directed(traj[i], traj[j])[0])


def test_modified_hausdorff_ignores_an_outlying_point() -> None:
    spike = LINE.copy()
    spike[3] = [3.0, 10.0]
    traj, mask = np.stack([LINE, spike]), np.ones((2, 4), bool)
    plain = pairwise_distances(traj, mask, "hausdorff")[0, 1]
    robust = pairwise_distances(traj, mask, "modified", quantile=0.5)[0, 1]
    assert plain == pytest.approx(10.0) and robust < 1.0


@pytest.mark.parametrize(("n", "c"), [(1, 1), (2, 1), (3, 2), (4, 2), (5, 3), (6, 3)])
def test_cluster_count(n: int, c: int) -> None:
    assert cluster_count(n) == c


def test_two_walking_pairs_are_two_groups() -> None:
    t = np.arange(8)[:, None] * 0.5
    pair_a = [np.concatenate([t, 0 * t], 1), np.concatenate([t, 0 * t + 0.6], 1)]
    pair_b = [np.concatenate([8 - t, 0 * t + 6], 1), np.concatenate([8 - t, 0 * t + 6.7], 1)]
    traj = np.stack([pair_a[0], pair_b[0], pair_a[1], pair_b[1]])
    distances = pairwise_distances(traj, np.ones((4, 8), bool))
    for method in ("single", "average", "complete"):
        np.testing.assert_array_equal(agglomerative_groups(distances, method), [0, 1, 0, 1])


@pytest.mark.parametrize("method", ["single", "average", "complete"])
def test_batched_clustering_equals_scipy_without_ties(method: str) -> None:
    rng = np.random.default_rng(1)
    for n in (2, 3, 4, 7, 12, 24):
        points = rng.normal(size=(40, n, 2))
        distances = np.linalg.norm(points[:, :, None] - points[:, None], axis=-1)  # (40, n, n)
        got = agglomerative_groups_batched(distances, method)
        for labels, matrix in zip(got, distances, strict=True):
            count = (n + 1) // 2
            tree = linkage(squareform(matrix, checks=False), method)
            expected = canonical_labels(cut_tree(tree, n_clusters=count)[:, 0])
            np.testing.assert_array_equal(labels, expected)
        np.testing.assert_array_equal(got[:1], [agglomerative_groups(distances[0], method)])
    np.testing.assert_array_equal(agglomerative_groups(np.zeros((1, 1)), method), [0])


def test_clustering_is_deterministic_with_ties() -> None:
    distances = np.ones((6, 6)) - np.eye(6)  # every pair tied
    first = agglomerative_groups(distances)
    for _ in range(5):
        np.testing.assert_array_equal(agglomerative_groups(distances), first)
    assert len(np.unique(first)) == 3


def test_sample_groups_put_the_walking_neighbour_with_the_ego(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    samples = scene_samples(scene, DataConfig(), 8)
    groups = assign_groups(samples, GroupConfig(), 3.0)
    assert (groups.num_groups == (samples.num_neighbours + 2) // 2).all()
    assert (groups.ego_group == 0).all()  # ego first: canonical group 0
    assert (groups.nbr_group == 0).all()  # C(2) = 1: the only neighbour shares it


def test_label_file_merging_blank_lines_and_header(tmp_path: Path) -> None:
    path = tmp_path / "groups.txt"
    path.write_text("4\n 5 4\n\n 6 3 2\n 241 242 238 238\n 238 320\n")
    labels = read_group_labels(path)  # "4" is a count header: 4 lines follow
    assert labels[5] == labels[4] and labels[6] == labels[2]
    assert labels[241] == labels[320] == labels[238]
    assert len(set(labels.values())) == 3
    no_header = tmp_path / "plain.txt"
    no_header.write_text("7\n1 2\n")  # "7" is not a count: a group of one
    assert set(read_group_labels(no_header)) == {1, 2, 7}
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2\n3 x\n")
    with pytest.raises(DataFormatError, match=r"bad.txt:2: expected pedestrian ids"):
        read_group_labels(bad)


def test_partitions_dice_and_id_map(tmp_path: Path) -> None:
    truth = partition_from_labels(np.array([1, 2, 3, 4]), {1: 0, 2: 0})
    assert truth[0] == truth[1] and len(set(truth.tolist())) == 3  # 3 and 4 alone
    assert dice_of_partitions(np.array([0, 0, 1, 2]), truth) == pytest.approx(1.0)
    assert dice_of_partitions(np.array([0, 0, 1, 1]), truth) == pytest.approx(2 * 1 / (2 + 3))
    mapping = tmp_path / "map.csv"
    mapping.write_text("track_id,label_id\n10,1\n11,2\n")
    assert read_id_map(mapping) == {10: 1, 11: 2}
    mapping.write_text("a,b\n1,2\n")
    with pytest.raises(DataFormatError, match="track_id,label_id"):
        read_id_map(mapping)


def test_groups_of_a_subset_align_with_the_subset(synthetic_data_dir: Path) -> None:
    from grouptron.data.datasets.dataset import load_part

    samples = load_part(synthetic_data_dir, "eth", "train", DataConfig()).samples
    groups = assign_groups(samples, GroupConfig(), 3.0)
    keep = samples.num_neighbours >= 2
    direct = assign_groups(samples.subset(keep), GroupConfig(), 3.0)
    subset = groups.subset(keep, samples)
    for name in ("ego_group", "nbr_group", "num_groups"):
        np.testing.assert_array_equal(getattr(subset, name), getattr(direct, name))


def test_a_partial_id_map_keeps_the_ids_it_does_not_list() -> None:
    from grouptron.groups.labels import apply_id_map

    labels = {1: 0, 2: 0, 3: 1, 4: 1, 5: 2}
    assert apply_id_map(labels, {10: 1}) == {10: 0, 2: 0, 3: 1, 4: 1, 5: 2}
    assert apply_id_map(labels, {3: 5, 5: 3}) == {1: 0, 2: 0, 3: 2, 4: 1, 5: 1}  # a swap
    assert apply_id_map(labels, {}) == labels


def test_the_one_set_fast_path_equals_the_stacked_distances() -> None:
    """A whole scene's (N, T, 2) set takes a faster path; a stack of one takes the general one."""
    rng = np.random.default_rng(3)
    traj = rng.normal(0, 4, (30, 8, 2))
    mask = rng.random((30, 8)) > 0.4
    mask[:, -1] = True  # everyone observed at t
    mask[0] = [False] * 7 + [True]  # seen once
    fast = pairwise_distances(traj, mask)
    general = pairwise_distances(traj[None], mask[None])[0]
    np.testing.assert_array_equal(fast, general)


@pytest.mark.parametrize("distance", ["hausdorff", "modified"])
def test_groups_from_the_step_matrix_equal_the_per_sample_groups(
    synthetic_data_dir: Path, distance: str
) -> None:
    """Live forecasting clusters every sample on sub-matrices of the step's distances."""
    from grouptron.data.datasets.dataset import load_scenes
    from grouptron.data.datasets.locate import split_files
    from grouptron.groups.assign import assign_groups_at_step
    from grouptron.groups.scene import groups_at_step

    data = DataConfig(derivatives="backward")
    config = GroupConfig(distance=distance)  # type: ignore[arg-type]
    (scene,) = load_scenes(split_files(synthetic_data_dir, "eth", "test"), data)
    compared = 0
    for step in range(scene.num_steps):
        samples = scene_samples(scene, data, 2, require_future=False, only_step=step)
        found = groups_at_step(scene, config, step)
        if not len(samples) or found is None:
            continue
        expected = assign_groups(samples, config, data.position_scale_m)
        got = assign_groups_at_step(samples, found.tracks, found.distances, config)
        for field in ("ego_group", "nbr_group", "num_groups"):
            np.testing.assert_array_equal(getattr(got, field), getattr(expected, field))
        compared += int((samples.num_neighbours >= 2).sum())
    assert compared > 20  # samples whose groups were not trivially one


@pytest.mark.parametrize("method", ["single", "average", "complete"])
def test_padded_sets_of_different_sizes_cluster_as_they_would_alone(method: str) -> None:
    from grouptron.groups.clustering import agglomerative_groups_batched

    rng = np.random.default_rng(7)
    sizes = np.array([1, 2, 3, 5, 8, 4])
    width = int(sizes.max())
    block = np.full((len(sizes), width, width), np.inf)
    alone = []
    for s, n in enumerate(sizes):
        points = rng.normal(0, 3, (n, 2))
        d = np.linalg.norm(points[:, None] - points[None], axis=-1)
        block[s, :n, :n] = d
        alone.append(agglomerative_groups(d, method))  # type: ignore[arg-type]
    padded = agglomerative_groups_batched(block, method, num_nodes=sizes)  # type: ignore[arg-type]
    for s, n in enumerate(sizes):
        np.testing.assert_array_equal(padded[s, :n], alone[s])


@pytest.mark.parametrize("method", ["single", "average", "complete"])
def test_a_whole_crowd_clusters_the_same_through_scipy(method: str) -> None:
    """Large single sets without ties go through SciPy's linkage; with ties they do not."""
    from grouptron.groups.clustering import SCIPY_FROM_NODES, agglomerative_groups_batched

    rng = np.random.default_rng(11)
    for n in (SCIPY_FROM_NODES, 60, 101):
        points = rng.normal(0, 5, (n, 2))
        d = np.linalg.norm(points[:, None] - points[None], axis=-1)
        expected = agglomerative_groups_batched(d[None], method)[0]  # type: ignore[arg-type]
        np.testing.assert_array_equal(agglomerative_groups(d, method), expected)  # type: ignore[arg-type]
        tied = np.round(d)  # many equal distances: the vectorised path decides ties
        expected = agglomerative_groups_batched(tied[None], method)[0]  # type: ignore[arg-type]
        np.testing.assert_array_equal(agglomerative_groups(tied, method), expected)  # type: ignore[arg-type]


def test_a_distance_threshold_cuts_the_dendrogram_at_that_height() -> None:
    """Hand-made: two pairs and a loner on a line; the threshold decides, not a group count."""
    from grouptron.groups.clustering import agglomerative_groups_batched

    x = np.array([0.0, 0.5, 3.0, 3.4, 10.0])
    d = np.abs(x[:, None] - x[None])
    np.testing.assert_array_equal(
        agglomerative_groups(d, "single", max_distance=1.0), [0, 0, 1, 1, 2]
    )
    np.testing.assert_array_equal(agglomerative_groups(d, "single", max_distance=0.3), range(5))
    np.testing.assert_array_equal(
        agglomerative_groups(d, "single", max_distance=3.0), [0] * 4 + [1]
    )
    # complete linkage: everyone in a group within the threshold of everyone else (3.4 > 3)
    np.testing.assert_array_equal(
        agglomerative_groups(d, "complete", max_distance=3.0), [0, 0, 1, 1, 2]
    )
    padded = np.full((2, 5, 5), np.inf)
    padded[0] = d
    padded[1, :3, :3] = d[2:, 2:]
    labels = agglomerative_groups_batched(
        padded, "single", num_nodes=np.array([5, 3]), max_distance=1.0
    )
    np.testing.assert_array_equal(labels[0], [0, 0, 1, 1, 2])
    np.testing.assert_array_equal(labels[1, :3], [0, 0, 1])


def test_walking_alike_groups_people_and_standing_beside_a_walker_does_not() -> None:
    from grouptron.groups.distances import group_distances

    t = np.arange(8) * 0.4
    walker = np.stack([0.5 * t, np.zeros(8)], -1)  # a slow walk, 1.4 m in the window
    partner = walker + np.array([0.0, 0.8])
    stander = np.stack([np.full(8, 0.7), np.full(8, 0.8)], -1)  # beside the walk's middle
    traj, mask = np.stack([walker, partner, stander]), np.ones((3, 8), bool)
    plain = group_distances(
        traj, mask, kind="hausdorff", quantile=0.9, velocity_weight_s=0.0, dt_s=0.4
    )
    alike = group_distances(
        traj, mask, kind="hausdorff", quantile=0.9, velocity_weight_s=4.0, dt_s=0.4
    )
    np.testing.assert_allclose(alike[0, 1], plain[0, 1])  # same velocity: no change
    np.testing.assert_allclose(alike[0, 2], 4.0 * 0.5)  # 0.5 m/s apart, weighed 4 s
    assert plain[0, 2] < 1.5 < alike[0, 2]
    for distances, expected in ((plain, [0, 0, 0]), (alike, [0, 0, 1])):
        labels = agglomerative_groups(distances, "single", max_distance=1.5)
        np.testing.assert_array_equal(labels, expected)


def test_threshold_groups_of_samples_count_their_own_groups(tmp_path: Path) -> None:
    """With a threshold a sample has as many groups as the cut leaves (2 nodes far apart: 2)."""
    scene = walking_scene(tmp_path)
    data = DataConfig()
    samples = scene_samples(scene, data, 2)
    config = GroupConfig(linkage="single", max_distance_m=0.01)  # nobody that close
    groups = assign_groups(samples, config, data.position_scale_m)
    np.testing.assert_array_equal(groups.num_groups, samples.num_neighbours + 1)
    assert (groups.ego_group == 0).all()
    wide = assign_groups(samples, GroupConfig(max_distance_m=1e6), data.position_scale_m)
    assert (wide.num_groups == 1).all() and (wide.nbr_group == 0).all()
    with pytest.raises(Exception, match="max_distance_m"):
        GroupConfig(max_distance_m=0.0)
    with pytest.raises(Exception, match="velocity_weight_s"):
        GroupConfig(velocity_weight_s=-1.0)


def test_group_rules_are_named_by_all_their_settings() -> None:
    assert describe_group_rule(GroupConfig()) == "C(N) rule"
    assert (
        describe_group_rule(DETECTION_GROUPS) == "single linkage, 1.5 m, 2 s x velocity, at most 6"
    )
    positions_only = GroupConfig(linkage="complete", max_distance_m=0.8)
    assert describe_group_rule(positions_only) == "complete linkage, 0.8 m"


@pytest.mark.parametrize("scipy_sized", [False, True])
def test_a_largest_group_size_cuts_a_chain_of_close_people(scipy_sized: bool) -> None:
    """People 1 m apart in a line: single linkage at 1.5 m chains them all; with a largest
    size every group stays within it, neighbours along the line still group, and a limit
    that no group reaches changes nothing."""
    count = 40 if scipy_sized else 9  # large sets take SciPy's path when unlimited
    x = np.arange(count, dtype=float) + np.linspace(0, 0.01, count)  # no ties
    distances = np.abs(x[:, None] - x[None, :])
    chained = agglomerative_groups(distances, "single", max_distance=1.5)
    assert (chained == 0).all()
    limited = agglomerative_groups(distances, "single", max_distance=1.5, max_size=4)
    sizes = np.bincount(limited)
    assert sizes.max() <= 4 and len(sizes) >= count // 4
    for group in range(len(sizes)):  # each group is a run of neighbours along the line
        members = np.flatnonzero(limited == group)
        assert np.all(np.diff(members) == 1)
    loose = agglomerative_groups(distances, "single", max_distance=1.5, max_size=count)
    np.testing.assert_array_equal(loose, chained)
    with pytest.raises(ValueError, match="max_distance"):
        agglomerative_groups(distances, "single", max_size=4)
    with pytest.raises(Exception, match="max_group_size"):
        GroupConfig(max_group_size=1)


def test_a_cut_at_a_height_ends_when_every_set_has_stopped_or_finished() -> None:
    """Padded sets cut at a height: once every set still owed merges has stopped at the
    height and the others have finished, the batch is done (a live crowd reached this state
    after about 2,000 updates and the empty remainder failed)."""
    inf = np.inf
    pair = [[0.0, 0.5, inf], [0.5, 0.0, inf], [inf, inf, 0.0]]  # two real nodes, close
    far = [[0.0, 9.0, 9.0], [9.0, 0.0, 9.0], [9.0, 9.0, 0.0]]  # three, beyond the height
    labels = agglomerative_groups_batched(
        np.array([pair, far]),
        "single",
        num_nodes=np.array([2, 3]),
        max_distance=1.0,
    )
    np.testing.assert_array_equal(labels, [[0, 0, 1], [0, 1, 2]])
