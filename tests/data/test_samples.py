"""Samples of a hand-made scene: windows, masks, standardisation, neighbours, edge weights."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.config import DataConfig
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.augment import ROTATION_ANGLES_DEG, draw_rotation_angles, rotate_samples
from grouptron.data.prepare.samples import SampleSet, concatenate_samples, scene_samples
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.geometry import rotate_xy_pairs, rotation_matrix
from tests.conftest import write_tracks
from tests.helpers.data import walking_scene

CONFIG = DataConfig()


def sample_at(samples: SampleSet, scene: Scene, ped_id: int, step: int) -> int:
    track = int(np.flatnonzero(scene.ped_id == ped_id)[0])
    hits = np.flatnonzero((samples.track == track) & (samples.step == step))
    assert hits.size == 1, f"no sample for pedestrian {ped_id} at step {step}"
    return int(hits[0])


def test_scene_drops_single_points_and_centres_on_all_positions(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    assert sorted(scene.ped_id.tolist()) == [1, 2, 3]
    all_xy = np.array(
        [[0.4 * s, 0.0] for s in range(25)]
        + [[0.4 * s, 10.0] for s in range(25)]
        + [[0.4 * s, 1.0] for s in range(3, 25)]
        + [[0.0, 5.0]]
    )
    np.testing.assert_allclose(scene.centre_world_m, all_xy.mean(axis=0))
    assert scene.num_steps == 25


def test_sample_counts_for_train_and_test_requirements(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    train = scene_samples(scene, CONFIG, min_history=2)
    test = scene_samples(scene, CONFIG, min_history=8)
    # train: t in 1..12 for 1 and 3, t in 4..12 for 2; test: t in 7..12, and 10..12 for 2.
    assert len(train) == 12 + 12 + 9
    assert len(test) == 6 + 6 + 3
    assert test.hist_mask.all()
    short = sample_at(train, scene, 1, 3)
    np.testing.assert_array_equal(train.hist_mask[short], [0, 0, 0, 0, 1, 1, 1, 1])
    assert (train.hist_st[short, :4] == 0).all() and (train.nbr_sum_st[short, :4] == 0).all()


def test_history_future_and_standardisation(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    samples = scene_samples(scene, CONFIG, min_history=8)
    s = sample_at(samples, scene, 1, 7)
    offsets_m = 0.4 * (np.arange(8) - 7)
    np.testing.assert_allclose(samples.hist_rel_m[s, :, 0], offsets_m, atol=1e-6)
    np.testing.assert_allclose(samples.hist_st[s, :, 0], offsets_m / 3.0, atol=1e-6)
    np.testing.assert_allclose(samples.hist_st[s, :, 2], 0.5, atol=1e-6)  # 1 m/s / 2
    np.testing.assert_allclose(samples.hist_st[s, :, [1, 3, 4, 5]], 0, atol=1e-6)
    np.testing.assert_allclose(samples.fut_rel_m[s, :, 0], 0.4 * np.arange(1, 13), atol=1e-6)
    assert samples.num_present[s] == 3


def test_neighbours_within_radius_and_their_state_sum(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    samples = scene_samples(scene, CONFIG, min_history=8)
    s = sample_at(samples, scene, 1, 7)
    track_2 = int(np.flatnonzero(scene.ped_id == 2)[0])
    assert samples.num_neighbours[s] == 1  # pedestrian 3 is 10 m away
    assert samples.nbr_track[samples.nbr_offsets[s]] == track_2
    # Pedestrian 2 is seen from step 3 (history index 3): (state_2 - state_1(t)) / scale.
    expected = np.zeros((8, 6))
    expected[3:, 0] = 0.4 * (np.arange(3, 8) - 7) / 3.0
    expected[3:, 1] = 1.0 / 3.0
    np.testing.assert_allclose(samples.nbr_sum_st[s], expected, atol=1e-6)
    edge = samples.nbr_offsets[s]
    np.testing.assert_allclose(samples.nbr_hist_st[edge], expected, atol=1e-6)  # one neighbour
    np.testing.assert_array_equal(samples.nbr_hist_mask[edge], [0, 0, 0, 1, 1, 1, 1, 1])


def test_edge_weights_ramp_in(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    samples = scene_samples(scene, CONFIG, min_history=2)
    weights = {
        t: float(samples.edge_weight_sum[sample_at(samples, scene, 1, t)])
        for t in (2, 3, 4, 5, 6, 7)
    }
    # The edge exists from step 3: 0.25, 0.25 + 0.5, 0.25 + 0.5 + 0.75 -> clipped at 1.
    assert weights == pytest.approx({2: 0.0, 3: 0.25, 4: 0.75, 5: 1.0, 6: 1.0, 7: 1.0})
    # Symmetric: pedestrian 2 sees pedestrian 1 from its first step, with the same weight.
    assert samples.edge_weight_sum[sample_at(samples, scene, 2, 4)] == pytest.approx(0.75)


def test_backward_scheme_changes_only_the_derivatives(tmp_path: Path) -> None:
    central = scene_samples(walking_scene(tmp_path), CONFIG, 2)
    config = DataConfig(derivatives="backward")
    backward = scene_samples(walking_scene(tmp_path, config), config, 2)
    np.testing.assert_array_equal(central.hist_rel_m, backward.hist_rel_m)
    np.testing.assert_array_equal(central.fut_rel_m, backward.fut_rel_m)
    # 1 m/s = 0.5 standardised wherever the point before was seen; a track's first point
    # has no velocity yet (0), whatever comes next.
    seen_before = backward.hist_mask[:, 1:] & backward.hist_mask[:, :-1]
    np.testing.assert_allclose(backward.hist_st[:, 1:, 2][seen_before], 0.5, atol=1e-6)
    first_seen = backward.hist_mask[:, 1:] & ~backward.hist_mask[:, :-1]
    assert first_seen.any()
    np.testing.assert_allclose(backward.hist_st[:, 1:, 2][first_seen], 0.0, atol=1e-6)


def random_scene_file(tmp_path: Path, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    rows = []
    for ped in range(6):
        start = int(rng.integers(0, 6))
        pos = rng.uniform(-2, 2, size=2)
        vel = rng.normal(0, 0.4, size=2)
        for step in range(start, 30):
            pos = pos + vel + rng.normal(0, 0.05, size=2)
            rows.append((step * 10, ped, round(pos[0], 3), round(pos[1], 3)))
    return write_tracks(tmp_path / "random.txt", rows)


@pytest.mark.parametrize("scheme", ["central", "backward"])
def test_rotating_the_scene_rotates_every_sample_vector(tmp_path: Path, scheme: str) -> None:
    config = DataConfig(derivatives=scheme)  # type: ignore[arg-type]
    table = read_tracks(random_scene_file(tmp_path))
    rotation = rotation_matrix(np.deg2rad(135.0))
    rotated_table = type(table)(**{**table.__dict__, "pos_m": table.pos_m @ rotation.T})
    plain = scene_samples(build_scene(table, config), config, 2)
    turned = scene_samples(build_scene(rotated_table, config), config, 2)
    np.testing.assert_array_equal(plain.nbr_track, turned.nbr_track)
    for name in ("hist_st", "nbr_sum_st", "fut_rel_m", "hist_rel_m", "nbr_hist_st"):
        np.testing.assert_allclose(
            rotate_xy_pairs(getattr(plain, name), rotation), getattr(turned, name), atol=1e-5
        )
    augmented = rotate_samples(plain, np.full(len(plain), np.deg2rad(135.0)))
    for name in (
        "hist_st",
        "nbr_sum_st",
        "fut_rel_m",
        "hist_rel_m",
        "pos_now_scene_m",
        "nbr_hist_st",
    ):
        np.testing.assert_allclose(getattr(augmented, name), getattr(turned, name), atol=1e-5)


def test_augmentation_angles_are_the_24_reference_ones(tmp_path: Path) -> None:
    angles = draw_rotation_angles(np.random.default_rng(0), 5000)
    assert set(np.round(np.rad2deg(angles)).astype(int)) == set(ROTATION_ANGLES_DEG.astype(int))
    samples = scene_samples(walking_scene(tmp_path), CONFIG, 2)
    angles = np.deg2rad(np.arange(len(samples)) * 15.0 % 360)
    turned = rotate_samples(samples, angles)
    # Each sample turns by its own angle; lengths are unchanged.
    np.testing.assert_allclose(
        np.linalg.norm(turned.fut_rel_m, axis=-1),
        np.linalg.norm(samples.fut_rel_m, axis=-1),
        atol=1e-5,
    )
    np.testing.assert_allclose(turned.fut_rel_m[6, -1], [0, 4.8], atol=1e-5)  # 90 degrees


def test_subset_and_concatenate_keep_neighbours(tmp_path: Path) -> None:
    scene = walking_scene(tmp_path)
    samples = scene_samples(scene, CONFIG, 2)
    keep = samples.num_neighbours > 0
    sub = samples.subset(keep)
    assert len(sub) == int(keep.sum())
    np.testing.assert_array_equal(sub.num_neighbours, samples.num_neighbours[keep])
    both = concatenate_samples([samples, sub])
    assert len(both) == len(samples) + len(sub)
    assert both.scene_index.max() == 1
    tail = slice(both.nbr_offsets[len(samples)], None)
    np.testing.assert_array_equal(both.nbr_track[tail], sub.nbr_track)
    round_trip = SampleSet.from_arrays(both.to_arrays())
    np.testing.assert_array_equal(round_trip.nbr_offsets, both.nbr_offsets)


def test_samples_of_one_step_equal_that_step_of_all_samples(tmp_path: Path) -> None:
    from tests.conftest import synthetic_recording

    config = DataConfig()
    table = read_tracks(synthetic_recording(tmp_path / "crowd.txt", seed=7, pedestrians=12))
    scene = build_scene(table, config)
    everything = scene_samples(scene, config, config.history_steps, require_future=False)
    compared = 0
    for step in range(scene.num_steps):
        alone = scene_samples(
            scene, config, config.history_steps, require_future=False, only_step=step
        )
        expected = everything.subset(everything.step == step)
        for name in SampleSet.__dataclass_fields__:
            got, want = getattr(alone, name), getattr(expected, name)
            if np.issubdtype(np.asarray(want).dtype, np.floating):  # prefix sums: rounding
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-6, err_msg=name)
            else:
                np.testing.assert_array_equal(got, want, name)
        compared += len(alone)
    assert compared == len(everything) > 50
