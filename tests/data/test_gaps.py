"""Filling missed detections: interpolation inside short gaps only."""

from __future__ import annotations

import numpy as np

from grouptron.data.prepare.gaps import bridge_gaps, filled_in_histories


def test_short_gaps_are_filled_on_the_line_between_their_ends() -> None:
    rows = np.array(
        [
            [0, 1, 0.0, 0.0],
            [30, 1, 3.0, 6.0],  # frames 10 and 20 missed
            [40, 1, 4.0, 8.0],
            [0, 2, 5.0, 5.0],
            [10, 2, 5.0, 6.0],
        ]
    )
    out, filled = bridge_gaps(rows, frames_per_step=10, max_missed_steps=2)
    assert filled.sum() == 2 and not filled[:5].any()
    np.testing.assert_array_equal(out[:5], rows)
    np.testing.assert_allclose(out[filled], [[10, 1, 1.0, 2.0], [20, 1, 2.0, 4.0]])


def test_longer_gaps_and_other_ids_are_left_alone() -> None:
    rows = np.array([[0, 1, 0.0, 0.0], [40, 1, 4.0, 0.0], [0, 2, 0.0, 0.0], [20, 3, 1.0, 1.0]])
    out, filled = bridge_gaps(rows, frames_per_step=10, max_missed_steps=2)  # 3 missed steps
    assert not filled.any()
    np.testing.assert_array_equal(out, rows)
    assert not bridge_gaps(rows, 10, 3)[1][:4].any() and bridge_gaps(rows, 10, 3)[1].sum() == 3
    assert not bridge_gaps(rows, 10, 0)[1].any()


def test_rows_in_any_order_and_off_grid_frames() -> None:
    rows = np.array([[20, 7, 2.0, 0.0], [0, 7, 0.0, 0.0], [25, 8, 0.0, 0.0], [0, 8, 0.0, 0.0]])
    out, filled = bridge_gaps(rows, frames_per_step=10, max_missed_steps=1)
    np.testing.assert_allclose(out[filled], [[10, 7, 1.0, 0.0]])  # id 8's 25 is not on the grid


def test_filled_positions_are_counted_inside_each_history_only() -> None:
    # Agent 1's history (frames 0..30, 4 points) holds the filled frame 10; agent 2's history
    # (frames 20..30) starts after its filled frame 10 and holds the one at its first frame 20;
    # agent 3 has no filled rows.
    filled = np.array([[10, 1], [10, 2], [20, 2], [40, 1]])  # (F, 2) frame, id; 40 is after
    counts = filled_in_histories(
        np.array([1, 2, 3]), 30, np.array([4, 2, 4]), filled, frames_per_step=10
    )
    np.testing.assert_array_equal(counts, [1, 1, 0])
