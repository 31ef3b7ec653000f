"""The prediction regions ``evaluate`` scores (``--regions``, ``--calibration``): requests
checked before anything is read, and the regions sized as ``predict`` draws them."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from grouptron.config import ExperimentConfig
from grouptron.constants import MAX_REGION_Q
from grouptron.errors import GrouptronError
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.inference.calibration import calibration_for
from grouptron.point_forecast import PointForecast, is_point_forecast


def refuse_meaningless_regions(
    checkpoint: str | Path | None,
    modes: Sequence[str] | None,
    qs: tuple[float, ...],
    calibration: str | Path | bool | None,
) -> None:
    """Refuse regions without a distribution (constant velocity, sampled modes alone), of
    probabilities outside (0, 0.99], and a calibration without regions."""
    if isinstance(qs, str | int | float):
        raise GrouptronError(f"regions is a sequence of probabilities such as (0.9,), not {qs!r}")
    if any(not 0.0 < q <= MAX_REGION_Q for q in qs):
        raise GrouptronError(f"--regions probabilities must be in (0, {MAX_REGION_Q}]: {qs}")
    if calibration not in (None, False) and not qs:
        raise GrouptronError("--calibration sizes prediction regions: give --regions too")
    if qs and checkpoint is None:
        raise GrouptronError(
            "constant velocity has no distribution to draw regions from: --regions needs a "
            "--checkpoint"
        )
    if qs and modes and not any(is_point_forecast(m) for m in modes):
        raise GrouptronError(f"--regions are a point forecast's; --mode {','.join(modes)} has none")


def region_scoring(
    experiment: ExperimentConfig | None,
    path: Path | None,
    modes: tuple[str, ...],
    qs: tuple[float, ...],
    calibration: str | Path | bool | None,
) -> RegionScoring | None:
    """The regions to score, as ``predict`` draws them: sized by the ``calibration`` file
    (which must belong to the checkpoint at ``path`` and every point forecast scored; checked
    before reading data), else by the one the checkpoint ships with where it fits every point
    forecast scored, else (and with ``calibration=False``) the model's own."""
    if not qs or experiment is None:
        return None
    qs = tuple(qs)
    if calibration is False:
        return RegionScoring(qs)
    checkpoint = str(path or "")
    found = [
        calibration_for(calibration, experiment, PointForecast.parse(m), checkpoint)
        for m in modes
        if is_point_forecast(m)
    ]
    if not found or any(c is None for c in found):  # no shipped one for some forecast
        return RegionScoring(qs)
    radii = {q: c.radius(q) for c in found[:1] if c is not None for q in qs}
    return RegionScoring(qs, radii)
