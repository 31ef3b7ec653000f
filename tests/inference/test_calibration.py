"""Split-conformal calibration of prediction regions: the guarantee, the file, the commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron import Predictor
from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import load_calibration
from grouptron.model.regions import conformal_radii


def test_conformal_radii_are_the_ranked_scores_and_keep_their_promise() -> None:
    scores = np.arange(1.0, 20.0)[:, None]  # n = 19, one step
    radii = conformal_radii(scores, np.array([0.5, 0.9, 0.95, 0.99]))
    # ceil(20 q)-th smallest: 10th, 18th, 19th, and past n for 0.99.
    assert radii[:, 0].tolist() == [10.0, 18.0, 19.0, np.inf]
    rng = np.random.default_rng(0)
    calibration, fresh = rng.gamma(2.0, size=(4000, 3)), rng.gamma(2.0, size=(40_000, 3))
    (radius,) = conformal_radii(calibration, np.array([0.9]))
    held = (fresh <= radius).mean(axis=0)
    assert np.all((held > 0.885) & (held < 0.915)), held


@pytest.fixture(scope="module")
def site(synthetic_data_dir: Path) -> tuple[Path, Path]:
    """An earlier and a later recording of one synthetic site."""
    return (
        split_files(synthetic_data_dir, "eth", "train")[0],
        split_files(synthetic_data_dir, "eth", "test")[0],
    )


def test_calibrate_writes_a_file_that_predict_and_the_api_apply(
    tiny_checkpoints: Path, site: tuple[Path, Path], tmp_path: Path
) -> None:
    earlier, later = site
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    calibration = tmp_path / "site.json"
    assert main(["calibrate", "--checkpoint", checkpoint, "--tracks", str(earlier),
                 "--out", str(calibration)]) == 0  # fmt: skip
    loaded = load_calibration(calibration)
    assert loaded.point_forecast == "ml-argmax" and loaded.samples > 50
    assert loaded.radii.shape == (99, 12) and np.all(np.diff(loaded.radii, axis=0) >= 0)

    rows = np.loadtxt(later)
    frame = int(rows[len(rows) // 2, 0])
    plain = Predictor.from_checkpoint(checkpoint).predict(rows, frame)
    sized = Predictor.from_checkpoint(checkpoint, calibration=calibration).predict(rows, frame)
    own, calibrated = plain.regions(0.9), sized.regions(0.9)
    np.testing.assert_allclose(calibrated.angle_rad, own.angle_rad)  # same shape, own size
    ratio = calibrated.major_m / own.major_m
    np.testing.assert_allclose(ratio, calibrated.minor_m / own.minor_m)
    assert not np.allclose(ratio, 1.0)
    with pytest.raises(GrouptronError, match=r"q = 0\.01, 0\.02"):
        sized.regions(0.905)

    out = tmp_path / "f.csv"
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(later), "--out", str(out),
            "--regions", "0.9", "--quiet"]  # fmt: skip
    assert main(argv) == 0
    uncalibrated = np.loadtxt(out, delimiter=",", skiprows=1)
    assert main([*argv, "--calibration", str(calibration)]) == 0
    calibrated_rows = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(calibrated_rows[:, :6], uncalibrated[:, :6])
    assert not np.allclose(calibrated_rows[:, 6], uncalibrated[:, 6])


def test_a_calibration_of_another_model_or_no_calibration_is_refused(
    tiny_checkpoints: Path, site: tuple[Path, Path], tmp_path: Path
) -> None:
    earlier, _ = site
    calibration = tmp_path / "site.json"
    argv = ["calibrate", "--tracks", str(earlier), "--out", str(calibration)]
    assert main([*argv, "--checkpoint", str(tiny_checkpoints / "grouptron-eth-backward")]) == 0
    with pytest.raises(GrouptronError, match="calibrated for grouptron with its ml-argmax"):
        Predictor.from_checkpoint(
            "trajectron++-eth-central", tiny_checkpoints, calibration=calibration
        )
    central = tmp_path / "central.json"  # the same model and forecast, other weights
    assert main(["calibrate", "--tracks", str(earlier), "--out", str(central), "--checkpoint",
                 str(tiny_checkpoints / "grouptron-eth-central")]) == 0  # fmt: skip
    with pytest.raises(GrouptronError, match="other weights"):
        Predictor.from_checkpoint("grouptron-eth-backward", tiny_checkpoints, calibration=central)
    document = json.loads(calibration.read_text())
    document["format"] = "something else"
    calibration.write_text(json.dumps(document))
    with pytest.raises(GrouptronError, match="not a grouptron calibration file"):
        load_calibration(calibration)
    with pytest.raises(GrouptronError, match="cannot read"):
        load_calibration(tmp_path / "missing.json")


def test_export_stores_a_calibration_of_its_checkpoint(
    tiny_checkpoints: Path, site: tuple[Path, Path], tmp_path: Path
) -> None:
    onnx = pytest.importorskip("onnx")
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    calibration, out = tmp_path / "site.json", tmp_path / "m.onnx"
    assert main(["calibrate", "--checkpoint", checkpoint, "--tracks", str(site[0]),
                 "--out", str(calibration)]) == 0  # fmt: skip
    argv = ["export", "--checkpoint", checkpoint, "--out", str(out), "--no-check"]
    assert main([*argv, "--calibration", str(calibration)]) == 0
    meta = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    stored = json.loads(meta["grouptron.region_calibration"])
    assert stored == json.loads(calibration.read_text())
    assert meta["grouptron.point_forecast"] == "ml-argmax"
    other = str(tiny_checkpoints / "grouptron-eth-central")  # other weights: refused
    assert main(["export", "--checkpoint", other, "--out", str(tmp_path / "o.onnx"),
                 "--calibration", str(calibration)]) == 2  # fmt: skip


def test_a_calibration_of_all_latent_values_does_not_fit_a_few(
    tiny_checkpoints: Path, site: tuple[Path, Path], tmp_path: Path
) -> None:
    """``ml`` of all Z latent values and ``ml`` of the 3 most probable are other forecasts with
    other regions: a file made for one is refused for the other."""
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    calibration = tmp_path / "ml.json"
    assert main(["calibrate", "--checkpoint", checkpoint, "--tracks", str(site[0]),
                 "--forecast", "ml", "--out", str(calibration)]) == 0  # fmt: skip
    Predictor.from_checkpoint(checkpoint, forecast="ml", calibration=calibration)
    with pytest.raises(GrouptronError, match="not grouptron with ml-top3"):
        Predictor.from_checkpoint(checkpoint, forecast="ml-top3", calibration=calibration)


def test_a_calibration_outlives_a_change_of_stored_settings_but_not_of_weights(
    tiny_checkpoints: Path, site: tuple[Path, Path], tmp_path: Path
) -> None:
    """The file ties itself to the checkpoint's tensors: storing a chosen point forecast in the
    checkpoint keeps it; other weights, and a file made before (whole-file digest) of
    unchanged weights, are told apart."""
    import dataclasses
    import shutil

    from grouptron.inference.calibration import _file_digest, calibration_for, weights_digest
    from grouptron.model.checkpoint import load_checkpoint, save_checkpoint
    from grouptron.point_forecast import PointForecast

    earlier, _ = site
    argmax = PointForecast.parse("ml-argmax")
    folder = tmp_path / "model"
    shutil.copytree(tiny_checkpoints / "grouptron-eth-backward", folder)
    path = folder / "best.safetensors"
    calibration = tmp_path / "site.json"
    argv = ["calibrate", "--tracks", str(earlier), "--out", str(calibration)]
    assert main([*argv, "--checkpoint", str(path)]) == 0
    before = weights_digest(path)
    stored = load_checkpoint(path)
    stored.config = dataclasses.replace(stored.config, point_forecast="ml-argmax")
    save_checkpoint(path, stored)
    assert weights_digest(path) == before and _file_digest(path) != before
    loaded = load_checkpoint(path)
    assert calibration_for(calibration, loaded.config, argmax, str(path)) is not None
    older = load_calibration(calibration)
    older = dataclasses.replace(older, weights_sha256=_file_digest(path))
    assert calibration_for(older, loaded.config, argmax, str(path)) is older
    stored.model_state = {k: v + 1.0 for k, v in stored.model_state.items()}
    save_checkpoint(path, stored)
    assert weights_digest(path) != before
    with pytest.raises(GrouptronError, match="other weights"):
        calibration_for(calibration, loaded.config, argmax, str(path))
