from __future__ import annotations

import numpy as np

from grouptron.baselines.constant_velocity import constant_velocity


def test_repeats_the_last_displacement() -> None:
    hist = np.zeros((1, 8, 2))
    hist[0, :, 0] = np.arange(-7, 1) * 0.5  # 0.5 m per step along x, ending at the origin
    hist[0, -2] = [-0.3, -0.4]  # only the last displacement counts
    pred = constant_velocity(hist, 12)
    assert pred.shape == (1, 12, 2)
    np.testing.assert_allclose(pred[0], np.arange(1, 13)[:, None] * [0.3, 0.4])


def test_standing_still_stays_put() -> None:
    np.testing.assert_array_equal(constant_velocity(np.zeros((3, 8, 2)), 12), 0.0)
