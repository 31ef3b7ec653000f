"""Golden outputs of what ships: the default model with its own point forecast, its regions
without a calibration, with one and with the one it ships with, and those calibrations' radii
(``tests/golden/default_model.py`` says how they were made; the first three equal those of the
code before the forecasting core was made one). Checked by breaking the code on purpose:
renaming the stored point forecast to ``ml-top3``, or scaling ``model.regions``' mass radius by
1.01, fails these tests."""

from __future__ import annotations

import numpy as np
import pytest

from tests.golden import default_model

TOLERANCES = {
    "point": 2e-4,
    "radii": 1e-4,
    "shipped/radii": 1e-4,
    "shipped/whole_path_radii": 1e-4,
    "regions": 2e-4,
}  # metres (angles: radians); radii in units of the region's shape


@pytest.fixture(scope="module")
def golden() -> dict[str, np.ndarray]:
    with np.load(default_model.GOLDEN, allow_pickle=False) as stored:
        return {key: stored[key] for key in stored.files}


@pytest.fixture(scope="module")
def now() -> dict[str, np.ndarray]:
    return default_model.compute()


def test_the_default_model_forecasts_regions_and_radii_as_stored(
    golden: dict[str, np.ndarray], now: dict[str, np.ndarray]
) -> None:
    assert sorted(now) == sorted(golden)
    np.testing.assert_array_equal(now["ids"], golden["ids"])
    for key in golden:
        kind = key if key in TOLERANCES else "regions"
        np.testing.assert_allclose(now[key], golden[key], rtol=1e-5, atol=TOLERANCES[kind])


def test_calibrated_regions_differ_from_the_models_own(golden: dict[str, np.ndarray]) -> None:
    """The pins would catch a calibration that is ignored: its regions are not the own ones."""
    assert len(golden["ids"]) >= 6 and np.isfinite(golden["radii"]).all()
    assert not np.allclose(golden["own/q0.9"][:2], golden["calibrated/q0.9"][:2], rtol=0.05)
