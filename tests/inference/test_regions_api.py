"""Prediction regions through the Python API and ``grouptron predict --regions``."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from grouptron import Predictor
from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from grouptron.errors import GrouptronError


@pytest.fixture(scope="module")
def recording(synthetic_data_dir: Path) -> np.ndarray:
    return np.loadtxt(split_files(synthetic_data_dir, "eth", "test")[0])


@pytest.mark.parametrize("point", ["ml-argmax", "ml-top10", "mean"])
def test_a_forecast_carries_the_distribution_its_point_forecast_was_made_from(
    tiny_checkpoints: Path, recording: np.ndarray, point: str
) -> None:
    predictor = Predictor.from_checkpoint(
        "grouptron-eth-backward", tiny_checkpoints, forecast=point
    )
    components = predictor.decoded_latent_values  # 1, min(10, Z) and Z
    forecast = predictor.predict(recording, t=int(recording[len(recording) // 2, 0]))
    N, H = forecast.point.shape[:2]
    distribution = forecast.distribution
    assert distribution is not None and distribution.components == components
    assert distribution.means.shape == (N, components, H, 2)
    assert distribution.covariances.shape == (N, components, H, 2, 2)
    np.testing.assert_allclose(np.exp(distribution.log_weights).sum(axis=1), 1.0)
    if components == 1:  # the argmax latent's means are the point forecast
        np.testing.assert_allclose(distribution.means[:, 0], forecast.point, atol=1e-5)
    regions = {q: forecast.regions(q) for q in (0.5, 0.9)}
    for region in regions.values():
        assert region.major_m.shape == (N, H)
        assert np.all(region.major_m >= region.minor_m) and np.all(region.minor_m > 0)
        assert np.all(np.abs(region.angle_rad) <= np.pi / 2)
        assert region.contains(forecast.point).all()  # the centre is inside
    assert np.all(regions[0.9].major_m > regions[0.5].major_m)
    # Uncertainty grows with the horizon.
    assert np.all(regions[0.9].major_m[:, -1] > regions[0.9].major_m[:, 0])
    with pytest.raises(GrouptronError, match=r"q must be in \(0, 0.99\]"):
        forecast.regions(1.0)


def test_predict_writes_region_columns_and_refuses_them_with_samples(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    tracks = split_files(synthetic_data_dir, "eth", "test")[0]
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    out = tmp_path / "f.csv"
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--out", str(out)]
    assert main([*argv, "--regions", "0.5,0.9", "--quiet"]) == 0
    with out.open() as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0])[6:] == [
        f"q{q}_{part}" for q in (50, 90) for part in ("major_m", "minor_m", "angle_rad")
    ]
    assert all(float(r["q90_major_m"]) > float(r["q50_major_m"]) > 0 for r in rows)
    assert main([*argv, "--regions", "0.9", "--forecast", "samples"]) == 2
    assert main([*argv, "--regions", "0,9"]) == 2


def test_uncalibrated_regions_say_once_that_their_size_is_no_promise(
    tiny_checkpoints: Path, recording: np.ndarray, caplog: pytest.LogCaptureFixture
) -> None:
    from grouptron.inference import forecast as forecast_module

    forecast_module._say_regions_are_uncalibrated.cache_clear()
    predictor = Predictor.from_checkpoint("grouptron-eth-backward", tiny_checkpoints)
    forecast = predictor.predict(recording, t=int(recording[len(recording) // 2, 0]))
    caplog.clear()
    for q in (0.5, 0.9):
        forecast.regions(q)
    told = [r.getMessage() for r in caplog.records if "without a calibration" in r.getMessage()]
    assert len(told) == 1 and "grouptron calibrate" in told[0]
