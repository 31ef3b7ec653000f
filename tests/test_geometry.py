"""Derivatives on hand-computed tracks, for both schemes, and rotations."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.geometry import rotate_xy_pairs, rotation_matrix, track_derivative, track_states

DT = 0.5
# Two tracks: x = 0, 1, 4, 9 (y = 0) and a two-point track.
POS = np.array([[0, 0], [1, 0], [4, 0], [9, 0], [2, 2], [3, 4]], dtype=float)
TRACK = np.array([0, 0, 0, 0, 1, 1])


def test_central_matches_hand_values_and_np_gradient() -> None:
    states = track_states(POS, TRACK, DT, "central")
    np.testing.assert_allclose(states[:4, 2], [2, 4, 8, 10])  # (x[t+1] - x[t-1]) / 2dt inside
    np.testing.assert_allclose(states[:4, 4], [4, 6, 6, 4])
    np.testing.assert_allclose(states[4:, 2:4], [[2, 4], [2, 4]])
    np.testing.assert_allclose(states[4:, 4:], 0)
    np.testing.assert_allclose(states[:4, 2], np.gradient(POS[:4, 0], DT))


def test_backward_matches_hand_values() -> None:
    states = track_states(POS, TRACK, DT, "backward")
    np.testing.assert_allclose(states[:4, 2], [0, 2, 6, 10])  # v[0] unknown: 0, never v[1]
    np.testing.assert_allclose(states[:4, 4], [0, 0, 8, 8])  # a needs two earlier points
    np.testing.assert_allclose(states[4:, 2:4], [[0, 0], [2, 4]])
    np.testing.assert_allclose(states[4:, 4:], 0)


def test_backward_with_the_reference_start_copies_the_next_value() -> None:
    states = track_states(POS, TRACK, DT, "backward", backward_start="next")
    np.testing.assert_allclose(states[:4, 2], [2, 2, 6, 10])  # v[0] = v[1], reads x[1]
    np.testing.assert_allclose(states[:4, 4], [0, 0, 8, 8])
    np.testing.assert_allclose(states[4:, 2:4], [[2, 4], [2, 4]])


def test_backward_is_causal() -> None:
    for cut in range(1, 4):  # a track cut after row `cut` has the same states up to it
        short = track_states(POS[: cut + 1], TRACK[: cut + 1], DT, "backward")
        np.testing.assert_array_equal(short, track_states(POS, TRACK, DT, "backward")[: cut + 1])
    changed = POS.copy()
    changed[3] = [100, -7]  # only the last point of track 0 changes
    before = track_states(POS, TRACK, DT, "backward")
    after = track_states(changed, TRACK, DT, "backward")
    np.testing.assert_allclose(before[:3], after[:3])
    central_after = track_states(changed, TRACK, DT, "central")
    assert not np.allclose(track_states(POS, TRACK, DT, "central")[2], central_after[2])


def test_single_point_track_gets_zero_derivative() -> None:
    assert track_derivative(np.array([[3.0, 4.0]]), np.array([0]), DT, "central").tolist() == [
        [0.0, 0.0]
    ]


def test_unknown_scheme_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown derivative scheme"):
        track_derivative(POS, TRACK, DT, "forward")  # type: ignore[arg-type]


@pytest.mark.parametrize("scheme", ["central", "backward"])
def test_rotating_states_equals_recomputing_from_rotated_positions(scheme: str) -> None:
    rotation = rotation_matrix(np.deg2rad(75.0))
    from_rotated = track_states(POS @ rotation.T, TRACK, DT, scheme)  # type: ignore[arg-type]
    rotated = rotate_xy_pairs(track_states(POS, TRACK, DT, scheme), rotation)  # type: ignore[arg-type]
    np.testing.assert_allclose(from_rotated, rotated, atol=1e-12)


def test_rotation_by_90_degrees() -> None:
    np.testing.assert_allclose(
        rotate_xy_pairs(np.array([1.0, 0.0, 0.0, 2.0]), rotation_matrix(np.pi / 2)),
        [0.0, 1.0, -2.0, 0.0],
        atol=1e-12,
    )


def test_poses_between_odometry_messages_by_name() -> None:
    from grouptron.geometry import poses_at

    times = np.array([0.0, 1.0, 3.0])
    poses = np.array([[0.0, 0.0, 3.0], [1.0, 2.0, -3.0], [5.0, 5.0, 0.0]])  # +3 -> -3 rad
    query = np.array([0.5, 1.0, 2.0, -0.1, 3.5])
    out, found = poses_at(times, poses, query, max_gap_s=1.5)
    assert found.tolist() == [True, True, False, False, False]  # a 2 s gap, before, after
    np.testing.assert_allclose(out[0, :2], [0.5, 1.0])
    # The shorter turn: from 3 rad to -3 rad is 0.28 rad through pi, not 6 rad back.
    assert abs(abs(out[0, 2]) - (3.0 + (2 * np.pi - 6.0) / 2)) < 1e-9
    np.testing.assert_allclose(out[1], poses[1])


def test_a_sensor_on_a_base_places_points_as_composed_transforms() -> None:
    from grouptron.geometry import compose_poses, fixed_from_body

    base = np.array([2.0, 1.0, np.pi / 2])  # facing +y
    mount = np.array([0.5, 0.0, np.pi])  # half a metre ahead, looking back
    point = np.array([[1.0, 0.0]])  # a metre in front of the sensor
    np.testing.assert_allclose(fixed_from_body(point, compose_poses(base, mount)), [[2.0, 0.5]])
    np.testing.assert_allclose(
        fixed_from_body(fixed_from_body(point, mount), base), [[2.0, 0.5]], atol=1e-12
    )
