"""The forecast: what every prediction path of grouptron returns."""

from __future__ import annotations

import dataclasses
import functools
import logging
from dataclasses import dataclass

import numpy as np

from grouptron.data.formats.time_base import TimeBase
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import RegionCalibration
from grouptron.inference.online import ForecastRadii
from grouptron.model.mixture import Mixture
from grouptron.model.regions import MAX_COVERAGE, Regions, calibrated_regions, prediction_regions

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)  # arrays have no single truth value: compare by identity
class Forecast:
    """Forecasts of ``N`` (agent, frame) pairs, positions in the input's coordinates: the one
    result type of the Python API (``Predictor``) and of whole-file forecasts.

    Attributes:
        frame: the frame every forecast was made from (the last observation used), or None
            when they come from several frames (a whole file).
        frames: (N,) the frame of every forecast.
        ids: (N,) agent ids (ascending within a frame).
        point: (N, H, 2) the point forecast's positions at steps 1..H after ``frame`` (the
            forecast the predictor was made with: ``ml``, ``ml-argmax``, ``mean`` or
            ``ml-topK``); ``most_likely`` is its older name.
        samples: (N, K, H, 2) sampled futures, or None when none were asked for.
        distribution: the Gaussians of the M latent values the point forecast was made from
            (K for ``ml-topK``, 1 for ``ml-argmax``, all Z for ``ml`` and ``mean``), their
            weights renormalised over them, in the input's coordinates; what ``regions`` draws
            from; None when not kept.
        mixture: the Gaussians of all Z latent values and their weights p(z|x) (None unless
            the predictor was made with ``mixture=True``).
        group: (N,) scene-wide group of every agent at ``frame`` (agglomerative clustering of
            everyone present on their histories by the predictor's ``group_rule``: the model's
            own for a model that reads groups, else the distance rule ``DETECTION_GROUPS``
            (``grouptron groups detect --detector distance``); numbered from 0), or None.
        observed_points: (N,) observed positions in the history each forecast read (at most
            ``history_steps``; fewer for agents seen only recently), or None.
        filled_points: (N,) positions of that history filled in for missed detections (not
            counted in ``observed_points``), or None.
        time_s: the time in seconds every forecast was made at, for a session fed times in
            seconds (then ``frame`` is None), else None.
        calibration: conformal radii of a site's recording (``grouptron calibrate``), the radii
            an online calibration had in force (one set, or per forecast for a replayed
            file), that ``regions`` takes instead of the distribution's own, or None.
    """

    frame: int | None
    frames: np.ndarray
    ids: np.ndarray
    point: np.ndarray
    samples: np.ndarray | None = None
    distribution: Mixture | None = None
    mixture: Mixture | None = None
    group: np.ndarray | None = None
    observed_points: np.ndarray | None = None
    filled_points: np.ndarray | None = None
    calibration: RegionCalibration | ForecastRadii | None = None
    time_s: float | None = None

    @property
    def most_likely(self) -> np.ndarray:
        """(N, H, 2) the point forecast (``point``; the older name)."""
        return self.point

    def __len__(self) -> int:
        return len(self.ids)

    def rows(self, index: np.ndarray, ids: np.ndarray | None = None) -> Forecast:
        """The forecasts ``index`` selects, in its order (with ``ids`` instead of their own)."""

        def pick(array: np.ndarray | None) -> np.ndarray | None:
            return None if array is None else array[index]

        radii = self.calibration
        if isinstance(radii, ForecastRadii):
            radii = ForecastRadii(radii.qs, radii.radii[index])
        return dataclasses.replace(
            self,
            frames=self.frames[index],
            ids=self.ids[index] if ids is None else ids,
            point=self.point[index],
            samples=pick(self.samples),
            distribution=None if self.distribution is None else self.distribution.rows(index),
            mixture=None if self.mixture is None else self.mixture.rows(index),
            group=pick(self.group),
            observed_points=pick(self.observed_points),
            filled_points=pick(self.filled_points),
            calibration=radii,
        )

    def table(
        self,
        sampled: bool = False,
        regions: tuple[float, ...] = (),
        time_base: TimeBase | None = None,
        joint: bool = False,
    ) -> tuple[list[str], np.ndarray, list[str]]:
        """CSV header, rows and number formats of the forecasts, layout 2 (docs/guide.md,
        "Forecast files"): ``frame, id, step, x_m, y_m`` of the point forecasts (or of the
        samples, with a ``sample`` column); ``step`` k is the position k steps of 0.4 s after
        the forecast time. With the input's ``time_base``, ``frame`` is the input's own frame
        number (the nearest one where 0.4 s is not a whole number of frames; 0.4 s steps from
        its first time for a file in seconds) and ``t_s`` its own time in seconds. Each
        probability of ``regions`` adds its ellipse's ``qQ_major_m, qQ_minor_m,
        qQ_angle_rad`` (point forecasts only; with ``joint``, whole-path regions)."""
        if sampled and self.samples is None:
            raise GrouptronError("this forecast holds no samples")
        positions = self.samples if sampled else self.point[:, None]
        assert positions is not None
        S, K, H, _ = positions.shape  # (N, K, H, 2)
        s, k, h = (a.ravel() for a in np.indices((S, K, H)))
        frames = self.frames
        if time_base is not None:
            own = time_base.file_frames(self.frames)
            frames = self.frames if own is None else own
        columns = [frames[s], self.ids[s], h + 1, *positions[s, k, h].T]
        header = ["frame", "id", "step", "x_m", "y_m"]
        formats = ["%d", "%.10g", "%d", "%.6f", "%.6f"]  # micrometres: scores agree to 1e-6 m
        if time_base is not None:
            columns.append(time_base.seconds(self.frames)[s])
            header.append("t_s")
            formats.append("%.16g")
        if sampled:
            columns.append(k)
            header.append("sample")
            formats.append("%d")
        elif regions:
            for q in regions:
                region = self.regions(q, joint=joint)
                label = f"q{100 * q:g}"
                columns += [a[s, h] for a in (region.major_m, region.minor_m, region.angle_rad)]
                header += [f"{label}_major_m", f"{label}_minor_m", f"{label}_angle_rad"]
                formats += ["%.4f", "%.4f", "%.4f"]
        return header, np.stack([np.asarray(c, dtype=np.float64) for c in columns], 1), formats

    def regions(self, q: float, joint: bool = False) -> Regions:
        """Per forecast and step, the ellipse around the point forecast holding probability
        ``q`` (0 < q <= 0.99) of the distribution the point forecast was made from (the
        mixture of its latent values' Gaussians): ``Regions`` of (N, H) semi-axes and angles.
        Their coverage on recordings is measured, not promised (benchmarks/RESULTS.md); with
        a ``calibration`` (q = 0.01, 0.02, ... 0.99) their size is the site's conformal one.
        With ``joint`` (a calibration's whole-path radii), the H ellipses of a forecast
        together hold its whole path with probability ``q``, for planners that check a
        trajectory rather than a point."""
        if self.distribution is None:
            raise GrouptronError(
                "this forecast holds no distribution to draw regions from (whole-file "
                "forecasts keep it when made with keep_distribution=True)"
            )
        if not 0.0 < q <= MAX_COVERAGE:
            raise GrouptronError(
                f"a region's probability q must be in (0, {MAX_COVERAGE}], not {q}"
            )
        if joint and not isinstance(self.calibration, RegionCalibration):
            raise GrouptronError(
                "whole-path regions (joint) need a calibration's whole-path radii (grouptron "
                "calibrate, or a checkpoint that ships one); online radii are per step"
            )
        if isinstance(self.calibration, RegionCalibration):
            radius = self.calibration.radius(q, joint=joint)
            return calibrated_regions(self.point, self.distribution, q, radius)
        if self.calibration is not None:
            return calibrated_regions(self.point, self.distribution, q, self.calibration.radius(q))
        _say_regions_are_uncalibrated()
        return prediction_regions(self.point, self.distribution, q)


@functools.cache
def _say_regions_are_uncalibrated() -> None:
    """Once per process: a region's own size is no promise (a planner may trust it)."""
    log.warning(
        "prediction regions without a calibration hold what the model's own distribution "
        "says, which on recordings from elsewhere can be far from q (benchmarks/RESULTS.md); "
        "grouptron calibrate sizes them for a site with a coverage guarantee (docs/regions.md)"
    )


def empty_forecast(
    frame: int, horizon: int, latent_values: int, decoded: int, num_samples: int, mixture: bool
) -> Forecast:
    """A forecast of nobody at ``frame``, with arrays of the shapes a full one would have."""
    H = horizon
    return Forecast(
        frame=frame,
        frames=np.zeros(0, dtype=np.int64),
        ids=np.zeros(0, dtype=np.int64),
        point=np.zeros((0, H, 2)),
        samples=np.zeros((0, num_samples, H, 2)) if num_samples else None,
        distribution=Mixture.empty(decoded, H),
        mixture=Mixture.empty(latent_values, H) if mixture else None,
        group=np.zeros(0, dtype=np.int64),
        observed_points=np.zeros(0, dtype=np.int64),
        filled_points=np.zeros(0, dtype=np.int64),
    )
