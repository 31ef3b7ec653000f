"""Golden outputs of what ships: the default model with its own point forecast (``ml-top2``),
its regions without a calibration, with one made here and with the one it ships with, and
those calibrations' radii, on the fixed scene of ``compute``. Regenerate ``default_model.npz``
only for an intended change of behaviour:

    python -m tests.golden.default_model
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.inference.calibration import calibrate
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.predictor import Predictor
from tests.golden.compute import FORECAST_FRAME, synthetic_tracks

GOLDEN = Path(__file__).parent / "default_model.npz"
REGION_QS = (0.5, 0.9)


def calibration_tracks() -> np.ndarray:
    """(R, 4) the scene three times over, each later and under new ids: 48 forecasts with a
    full future, enough for a calibration (``MIN_FORECASTS``)."""
    tracks = synthetic_tracks()
    later = [tracks + np.array([300.0 * k, 100.0 * k, 0.0, 0.0]) for k in range(3)]
    return np.concatenate(later)


def compute() -> dict[str, np.ndarray]:
    """The shipped default model's forecast at ``FORECAST_FRAME`` (its own point forecast),
    its regions, a calibration made on the scene's samples with a full future, and the
    regions drawn with it."""
    path = resolve_checkpoint(DEFAULT_CHECKPOINT)
    predictor = Predictor.from_checkpoint(path, calibration=False)
    shipped = Predictor.from_checkpoint(path)  # with the calibration it ships with
    assert shipped.calibration is not None
    tracks = synthetic_tracks()
    table = table_from_values(Path("golden"), calibration_tracks(), np.arange(3 * len(tracks)), 10)
    data = predictor.config.data
    samples = scene_samples(build_scene(table, data, name="golden"), data, data.history_steps)
    calibration = calibrate(predictor.model, predictor.config, samples, predictor.forecast)
    calibrated = Predictor.from_checkpoint(path, calibration=calibration)
    out = {"ids": np.asarray([]), "radii": calibration.radii[[49, 89]]}  # q = 0.5, 0.9
    out["shipped/radii"] = shipped.calibration.radii[[49, 89]]
    out["shipped/whole_path_radii"] = shipped.calibration.joint_radii[[49, 89]]
    for name, used in (("own", predictor), ("calibrated", calibrated), ("shipped", shipped)):
        forecast = used.predict(tracks, FORECAST_FRAME)
        out["ids"], out["point"] = forecast.ids.astype(np.float64), forecast.point
        for q in REGION_QS:
            region = forecast.regions(q)
            out[f"{name}/q{q:g}"] = np.stack([region.major_m, region.minor_m, region.angle_rad])
    return out


if __name__ == "__main__":
    np.savez_compressed(GOLDEN, **compute())
    print(f"wrote {GOLDEN}")
