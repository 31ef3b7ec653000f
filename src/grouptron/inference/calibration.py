"""Split-conformal calibration of prediction regions on a site's own recording, and the
calibration file that ships with a deployment (``RegionCalibration``).

Every person of the recording with a full history and future is forecast; the score of a
forecast step is the true position's Mahalanobis distance under its region's shape
(``model.regions.shape_distances``). Per step and probability q the calibrated radius is the
ceil((n + 1) q)-th smallest of the n scores, so that a new forecast whose score is exchangeable
with the calibration ones falls inside with probability at least q (docs/regions.md says what
that assumption means for tracks). The file is a few kilobytes of JSON.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.config import ExperimentConfig
from grouptron.constants import DT_S
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.io import document_errors, read_json_document, write_text_atomically
from grouptron.model.factory import groups_for_model
from grouptron.model.forecaster import Forecaster, latent_values_of
from grouptron.model.regions import conformal_radii, prediction_regions, shape_distances
from grouptron.point_forecast import PointForecast

FORMAT = "grouptron-calibration/1"
QS = np.round(np.arange(1, 100) / 100, 2)
"""The probabilities a calibration file holds radii for."""
MIN_FORECASTS = 20
"""Forecasts a calibration needs to support any q: fewer give radii that one person's walk
decides (and q needs at least q / (1 - q) of them besides: 9 for 0.9, 99 for 0.99)."""


@dataclass(frozen=True, eq=False)
class RegionCalibration:
    """Conformal radii of a site's recording for one checkpoint and point forecast.

    Attributes:
        checkpoint: the model's name (``config.model_name``) the scores were made with.
        point_forecast: its point forecast's name (``ml-top10``, ...).
        samples: calibration samples (people with a full history and future).
        qs: (Q,) probabilities, 0.01 to 0.99 in steps of 0.01.
        radii: (Q, H) the radius per probability and forecast step.
        source: the recording the scores came from.
        weights_sha256: the checkpoint file's SHA-256 (empty when unknown).
        uncalibrated_coverage_q90: (H,) the share of the recording's truths inside the
            model's own 90% regions per step (for the record; empty when unknown).
        step_s: seconds between forecast steps (``DataConfig.dt_s``).
        joint_scale: (H,) per step, the score that whole-path regions divide by (the
            calibration's median score); empty when the file has none.
        joint_radii: (Q,) per q, the radius of the largest scaled score over a path's steps:
            a whole-path region is step k's ellipse of radius ``joint_radii * joint_scale[k]``.
        density: the recording's median number of people within 3 m of each person.
        speed_mps: its median walking speed (m/s).
    """

    checkpoint: str
    point_forecast: str
    samples: int
    qs: np.ndarray
    radii: np.ndarray
    source: str = ""
    weights_sha256: str = ""
    uncalibrated_coverage_q90: np.ndarray = field(default_factory=lambda: np.zeros(0))
    step_s: float = DT_S
    joint_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))
    joint_radii: np.ndarray = field(default_factory=lambda: np.zeros(0))
    density: float = math.nan
    speed_mps: float = math.nan

    def radius(self, q: float, joint: bool = False) -> np.ndarray:
        """(H,) the calibrated radius at ``q`` (one of ``qs``), per step; with ``joint`` that
        of the whole-path region (its 12 ellipses together hold the path with probability q)."""
        match = np.flatnonzero(np.isclose(self.qs, q))
        if not len(match):
            raise GrouptronError(f"calibrated regions are for q = 0.01, 0.02, ... 0.99, not {q}")
        needed = max(MIN_FORECASTS, needed_forecasts(q))
        if self.samples < needed:
            raise GrouptronError(
                f"a calibration from {self.samples} forecasts cannot support q = {q:g}: it "
                f"needs at least {needed}; calibrate on a longer recording"
            )
        if joint and not len(self.joint_radii):
            raise GrouptronError(
                "this calibration has no whole-path radii (made before them): calibrate again"
            )
        scaled = self.joint_radii[match[0]] * self.joint_scale if joint else None
        radius: np.ndarray = self.radii[match[0]] if scaled is None else scaled
        return radius


def condition_mismatch(calibration: RegionCalibration, density: float, speed_mps: float) -> str:
    """How a site differs from where ``calibration`` was made, where it clearly does (half or
    twice the neighbours, a third slower or faster), else ""."""
    denser = (density + 1.0) / (calibration.density + 1.0)  # +1: a sparse site's 0 and 0.5
    faster = speed_mps / calibration.speed_mps if calibration.speed_mps > 0 else math.nan
    if not (denser > 2 or denser < 0.5 or faster > 1.5 or faster < 2 / 3):
        return ""  # alike, or one of them unknown (NaN compares false)
    return (
        f"calibrated where people had a median of {calibration.density:g} neighbours within "
        f"3 m and walked at {calibration.speed_mps:.2g} m/s; here {density:g} and "
        f"{speed_mps:.2g} m/s: its regions may not hold their q here (calibrate on this site, "
        "or adapt the radii with --online)"
    )


def needed_forecasts(q: float) -> int:
    """The fewest calibration forecasts whose conformal radius at ``q`` is finite."""
    return int(np.ceil(q / (1 - q) - 1e-9))


def calibration_scores(
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    forecast: PointForecast,
    batch_size: int = 512,
) -> tuple[np.ndarray, np.ndarray]:
    """(n, H) every sample's score per forecast step (samples with a full future), and (n, H)
    whether its truth lies in the model's own (uncalibrated) 90% region."""
    options = EngineOptions(batch_size=batch_size)
    made = forecast_samples(
        model, config, samples, forecast, groups_for_model(samples, config), options
    )
    assert made.distribution is not None
    truth = samples.fut_rel_m.astype(np.float64)  # (n, H, 2) relative to now, as the forecast
    scores = shape_distances(made.point, made.distribution, truth)
    inside = prediction_regions(made.point, made.distribution, 0.9).contains(truth)
    return scores, inside


def weights_digest(path: str | Path) -> str:
    """SHA-256 of a checkpoint's tensors (what ties a calibration to the weights it was made
    for): the bytes after a safetensors file's header, so a change of its stored settings
    alone (a chosen point forecast) keeps its calibrations."""
    return _digests(Path(path).read_bytes())[0]


def _file_digest(path: str | Path) -> str:
    """SHA-256 of the whole file: what calibrations stored before :func:`weights_digest`."""
    return _digests(Path(path).read_bytes())[1]


def _digests(data: bytes) -> tuple[str, str]:
    """SHA-256 of a checkpoint file's tensors and of the whole file."""
    header = 8 + int.from_bytes(data[:8], "little") if len(data) >= 8 else 0
    tensors = data[header:] if header <= len(data) else data
    return hashlib.sha256(tensors).hexdigest(), hashlib.sha256(data).hexdigest()


def calibrate(
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    forecast: PointForecast,
    source: str = "",
    weights_sha256: str = "",
) -> RegionCalibration:
    """The conformal radii of ``samples`` for ``model``'s point forecast ``forecast``."""
    if not len(samples):
        raise GrouptronError(
            f"{source or 'the recording'}: nobody has {config.data.history_steps} observed and "
            f"{config.data.horizon_steps} future steps, so there is nothing to calibrate on"
        )
    scores, inside = calibration_scores(model, config, samples, forecast)
    calibration = calibration_from_scores(scores, inside)
    return dataclasses.replace(
        calibration,
        checkpoint=config.model_name,
        point_forecast=forecast.name,
        source=source,
        weights_sha256=weights_sha256,
        step_s=config.data.dt_s,
    )


def calibration_from_scores(scores: np.ndarray, inside: np.ndarray) -> RegionCalibration:
    """The radii of (n, H) scores (and (n, H) truths inside the model's own 90% regions):
    per step, and of the whole path (the largest score over its steps, each divided by its
    step's median score)."""
    scale = conformal_radii(scores, np.array([0.5]))[0] if len(scores) else np.ones(0)
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    joint = (scores / scale).max(axis=1, keepdims=True) if len(scores) else np.zeros((0, 1))
    return RegionCalibration(
        checkpoint="",
        point_forecast="",
        samples=len(scores),
        qs=QS,
        radii=conformal_radii(scores, QS),
        uncalibrated_coverage_q90=inside.mean(axis=0) if len(inside) else np.zeros(0),
        joint_scale=scale,
        joint_radii=conformal_radii(joint, QS)[:, 0],
    )


def calibration_document(calibration: RegionCalibration) -> dict[str, object]:
    """The JSON document of a calibration file (an unreachable radius as null)."""
    radii = [
        [None if math.isinf(r) else round(float(r), 6) for r in row] for row in calibration.radii
    ]
    return {
        "format": FORMAT,
        "checkpoint": calibration.checkpoint,
        "point_forecast": calibration.point_forecast,
        "samples": calibration.samples,
        "source": calibration.source,
        "weights_sha256": calibration.weights_sha256,
        "uncalibrated_coverage_q90_per_step": [
            round(float(c), 4) for c in calibration.uncalibrated_coverage_q90
        ],
        "step_s": calibration.step_s,
        "density_median_neighbours_3m": _number(calibration.density),
        "speed_median_mps": _number(calibration.speed_mps),
        "q": [float(q) for q in calibration.qs],
        "radius_per_step": radii,
        "whole_path_scale_per_step": [round(float(s), 6) for s in calibration.joint_scale],
        "whole_path_radius": [_number(r) for r in calibration.joint_radii],
    }


def _number(value: float) -> float | None:
    """A finite number rounded for the file, else null."""
    return round(float(value), 6) if math.isfinite(value) else None


def save_calibration(calibration: RegionCalibration, path: Path) -> None:
    """Write ``calibration`` as JSON, one line per key."""
    document = calibration_document(calibration)
    lines = ",\n".join(
        f" {json.dumps(key)}: {json.dumps(value)}" for key, value in document.items()
    )
    write_text_atomically(path, "{\n" + lines + "\n}\n")  # one line per key: easy to read


def load_calibration(path: str | Path) -> RegionCalibration:
    """Read a calibration file written by :func:`save_calibration` (one line if it is not one)."""
    hint = "; make one with grouptron calibrate"
    with document_errors(path, "calibration file", "calibration file", hint):
        document: dict[str, Any] = read_json_document(path, FORMAT)
        radii = np.array(
            [[np.inf if r is None else r for r in row] for row in document["radius_per_step"]],
            dtype=np.float64,
        )
        if radii.ndim != 2 or len(radii) != len(document["q"]):
            raise ValueError("radius_per_step needs one row of radii per q")
        return RegionCalibration(
            checkpoint=str(document["checkpoint"]),
            point_forecast=str(document["point_forecast"]),
            samples=int(document["samples"]),
            qs=np.asarray(document["q"], dtype=np.float64),
            radii=radii,
            source=str(document.get("source", "")),
            weights_sha256=str(document.get("weights_sha256", "")),
            uncalibrated_coverage_q90=np.asarray(
                document.get("uncalibrated_coverage_q90_per_step", []), dtype=np.float64
            ),
            step_s=float(document.get("step_s", DT_S)),  # files before it: the 0.4 s step
            joint_scale=np.asarray(document.get("whole_path_scale_per_step", []), np.float64),
            joint_radii=_finite_or_inf(document.get("whole_path_radius", [])),
            density=_float_or_nan(document.get("density_median_neighbours_3m")),
            speed_mps=_float_or_nan(document.get("speed_median_mps")),
        )


def _finite_or_inf(values: list[float | None]) -> np.ndarray:
    """Radii read back: null (unreachable) as infinite."""
    return np.array([np.inf if v is None else v for v in values], dtype=np.float64)


def _float_or_nan(value: float | None) -> float:
    return math.nan if value is None else float(value)


SHIPPED_FILE = "calibration.json"
"""The calibration a checkpoint ships with, beside its weights (``campaign/ship_calibration.py``
fits it on files the model never trained on)."""


def shipped_calibration(checkpoint: str | Path) -> Path | None:
    """The calibration file shipped beside a checkpoint's weights, if it has one."""
    path = Path(checkpoint).parent / SHIPPED_FILE if checkpoint else None
    return path if path is not None and path.is_file() else None


def calibration_for(
    calibration: str | Path | RegionCalibration | bool | None,
    config: ExperimentConfig,
    forecast: PointForecast,
    checkpoint: str = "",
) -> RegionCalibration | None:
    """``calibration`` (a file or a loaded one), checked to belong to this model, point
    forecast and (when ``checkpoint``, its file, is known) these weights. None: the one the
    checkpoint ships with, where it has one for this forecast; False: none."""
    if calibration is False or calibration is True:
        if calibration:
            raise GrouptronError("calibration is a file, a RegionCalibration, None or False")
        return None
    if calibration is None:
        shipped = shipped_calibration(checkpoint)
        if shipped is None:
            return None
        loaded = load_calibration(shipped)
        Z = latent_values_of(config)
        if PointForecast.parse(loaded.point_forecast).for_model(Z) != forecast.for_model(Z):
            return None  # shipped for the model's own forecast, not this one
        calibration = loaded
    named = "" if isinstance(calibration, RegionCalibration) else f"{calibration}: "
    loaded = (
        calibration if isinstance(calibration, RegionCalibration) else load_calibration(calibration)
    )

    Z = latent_values_of(config)
    stored = PointForecast.parse(loaded.point_forecast).for_model(Z)
    if (loaded.checkpoint, stored) != (config.model_name, forecast.for_model(Z)):
        raise GrouptronError(
            f"{named}calibrated for {loaded.checkpoint} with its {loaded.point_forecast} "
            f"forecast, not {config.model_name} with {forecast}; calibrate this one"
        )
    known = bool(checkpoint and loaded.weights_sha256 and Path(checkpoint).is_file())
    if known and loaded.weights_sha256 not in _digests(Path(checkpoint).read_bytes()):
        raise GrouptronError(
            f"{named}calibrated for other weights of {loaded.checkpoint} than {checkpoint}; "
            "calibrate this checkpoint"
        )
    return loaded
