"""A dataset's report compares every row with the best of its kind of forecast, sample by
sample: one forecast (constant velocity's among them) apart from best-of-K."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.reporting.datasets import differences_to_best


def test_every_row_is_paired_with_the_best_of_its_kind() -> None:
    steps = np.repeat(np.arange(10), 4)
    base = np.linspace(1.0, 2.0, 40)
    scored = {
        ("backward", "constant-velocity"): ("one forecast", base, steps),
        ("backward", "a (ml)"): ("one forecast", base - 0.2, steps),
        ("backward", "b (ml)"): ("one forecast", base - 0.1, steps),
        ("backward", "a (best-of-20)"): ("best-of-20", base - 0.6, steps),
        ("backward", "b (best-of-20)"): ("best-of-20", base - 0.5, steps),
    }
    found = {d.row: d for d in differences_to_best(scored)}
    assert found["a (ml)"].best == "a (ml)" and found["a (ml)"].fde.mean == pytest.approx(0.0)
    assert found["constant-velocity"].best == "a (ml)"
    assert found["constant-velocity"].fde.mean == pytest.approx(0.2)
    assert found["b (ml)"].fde.low == pytest.approx(0.1)  # the same on every sample
    # best-of-20 rows are compared among themselves, not with the one-forecast rows
    assert found["b (best-of-20)"].best == "a (best-of-20)"
    assert found["b (best-of-20)"].fde.mean == pytest.approx(0.1)
