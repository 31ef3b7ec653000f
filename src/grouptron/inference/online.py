"""Online calibration of prediction regions: radii that follow a site as it drifts.

Every forecast is scored once its truth arrives (step k is known k steps later): the score is
the true position's Mahalanobis distance under the region's shape, as for a static
calibration. Per probability q and step k the radius r then moves by quantile tracking (the
P part of conformal PID control, Angelopoulos et al. 2023; adaptive conformal inference,
Gibbs & Candes 2021, works on the same error signal)::

    r <- r + lr * scale_k * (missed - (1 - q))        at every update with truths of step k

where ``missed`` is the share of the truths arriving at that update that fell outside the
radius their forecasts were made with. Summed over n updates these changes telescope:
``sum(missed) - n (1 - q) = (r_n - r_0) / (lr * scale_k)``, so while the radius stays bounded
(it does: it shrinks whenever it exceeds every score and grows whenever it is below them) the
long-run average share of misses tends to 1 - q, for any sequence of scores, at a rate 1 / n
(docs/regions.md). Nothing is assumed of the scores: not exchangeability, not stationarity.
Each q is tracked alone; the regions drawn take, for each q, the largest radius of any q up
to it, so that they nest, which can only add coverage.

The state (per q and step: the radius, the scores seen and the misses) is a few kilobytes,
belongs to one session or replay, and is saved and resumed as JSON.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.inference.calibration import QS, RegionCalibration
from grouptron.io import document_errors, read_json_document, write_text_atomically
from grouptron.model.regions import distances_under

FORMAT = "grouptron-online-calibration/1"
LEARNING_RATE = 0.3
"""Radius change per update, as a share of the step's scale (its starting 90% radius) and of
how far the update's share of misses is from 1 - q: 3% of the scale when coverage is 10
points off, so a corridor whose radii must halve is followed within a minute. Chosen on the
development recordings among 0.1, 0.2 and 0.3 (benchmarks/RESULTS.md, "Online
calibration"): the largest, as it was the only one to hold every step of every recording
within 88-92%."""


GAUSSIAN_PRIOR = 100
"""Forecasts the Gaussian starting radii stand for: enough for regions at every q up to 0.99
from the first update on (they are a guess that the updates correct, not a promise)."""


def gaussian_radii(qs: np.ndarray, horizon: int) -> np.ndarray:
    """(Q, H) the radii holding q of a 2-D Gaussian whose covariance is the region's shape:
    where radii start without a calibration."""
    radius = np.sqrt(-2.0 * np.log1p(-np.asarray(qs, dtype=np.float64)))
    return np.repeat(radius[:, None], horizon, axis=1)


@dataclass
class OnlineCalibration:
    """Per q and step, a radius adapted to the scores of forecasts whose truths arrived.

    Attributes:
        qs: (Q,) probabilities, 0.01 ... 0.99.
        radii: (Q, H) current radii (Mahalanobis units of the region's shape).
        scale: (H,) the step's scale, the starting radius at q = 0.9: steps of the update.
        scored: (H,) forecasts scored per step so far.
        missed: (Q, H) of those, how many fell outside the region drawn with them.
        learning_rate: the update's step, a share of ``scale`` per scored forecast.
        source: what the radii started from (a calibration file, or the Gaussian's).
        prior_samples: the forecasts the starting radii stand for (a calibration's; the
            Gaussian radii count as ``GAUSSIAN_PRIOR``), so that regions are drawn from the
            first update on.
    """

    qs: np.ndarray
    radii: np.ndarray
    scale: np.ndarray
    scored: np.ndarray
    missed: np.ndarray
    learning_rate: float = LEARNING_RATE
    source: str = ""
    prior_samples: int = 0
    _pending: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=list, repr=False
    )

    @classmethod
    def start(
        cls,
        horizon: int,
        calibration: RegionCalibration | None = None,
        learning_rate: float = LEARNING_RATE,
    ) -> OnlineCalibration:
        """Radii from ``calibration`` (a shipped or a site's), else the Gaussian's."""
        if not (isinstance(learning_rate, float | int) and 0 < learning_rate <= 1):
            raise GrouptronError(f"learning_rate must be in (0, 1], not {learning_rate!r}")
        qs = QS.astype(np.float64)
        radii = gaussian_radii(qs, horizon)
        source, prior = "the Gaussian radii", GAUSSIAN_PRIOR
        if calibration is not None:
            prior = calibration.samples
            known = np.isfinite(calibration.radii)  # unsupported q: from the Gaussian's
            radii = np.where(known, calibration.radii, radii)
            source = calibration.source or "a calibration"
        scale = radii[np.flatnonzero(np.isclose(qs, 0.9))[0]].copy()
        zeros = np.zeros(horizon, dtype=np.int64)
        missed = np.zeros(radii.shape, dtype=np.int64)
        return cls(qs, radii, scale, zeros, missed, float(learning_rate), source, prior)

    @property
    def horizon(self) -> int:
        """H, the forecast steps."""
        return int(self.radii.shape[1])

    def coverage(self) -> np.ndarray:
        """(Q, H) the share of scored truths inside the regions their forecasts were drawn
        with: the long-run coverage that the updates keep at q."""
        held: np.ndarray = 1.0 - self.missed / np.maximum(self.scored, 1)[None, :]
        return held

    def calibration(self) -> RegionCalibration:
        """The radii in force now, as a calibration that regions take."""
        return RegionCalibration(
            checkpoint="",
            point_forecast="",
            samples=self.prior_samples + int(self.scored.min()),
            qs=self.qs,
            radii=np.maximum.accumulate(self.radii, axis=0),  # regions that nest in q
            source=f"online, from {self.source}",
        )

    def remember(
        self, frame: float, ids: np.ndarray, point: np.ndarray, shapes: np.ndarray, step: float
    ) -> None:
        """Keep the forecasts made at ``frame`` ((N,) ids, (N, H, 2) points, (N, H, 2, 2)
        region shapes), with the radii they were drawn with, until their truths arrive,
        ``step`` frames per forecast step."""
        self._pending.append((frame, ids, point, shapes, self.radii.copy()))
        horizon_frames = self.horizon * step
        self._pending = [p for p in self._pending if p[0] >= frame - horizon_frames]

    def observe(self, frame: int, ids: np.ndarray, xy: np.ndarray, step: int) -> None:
        """Score every kept forecast whose step lands on ``frame`` against the (N, 2) positions
        of the (N,) ``ids`` seen there, and move the radii."""
        if not len(ids):
            return
        order = np.argsort(ids, kind="stable")
        seen_ids, seen_xy = ids[order], xy[order]
        for made, forecast_ids, point, shapes, drawn in self._pending:
            steps, off_grid = divmod(frame - made, step)
            k = int(steps)
            if off_grid or not 1 <= k <= self.horizon:
                continue
            at = np.clip(np.searchsorted(seen_ids, forecast_ids), 0, len(seen_ids) - 1)
            found = seen_ids[at] == forecast_ids
            if found.any():
                scores = distances_under(
                    point[found, k - 1], shapes[found, k - 1], seen_xy[at[found]]
                )
                self._update(k - 1, scores, drawn[:, k - 1])

    def observe_between(
        self,
        since: float,
        now: float,
        step: float,
        positions_at: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
    ) -> None:
        """Score every kept forecast whose step lands in (``since``, ``now``] (times in
        seconds, ``step`` seconds per forecast step) against the positions that
        ``positions_at(ids, times)`` gives there ((Q, 2) positions, (Q,) whether known), and
        move the radii: for a tracker's own rate, where truths fall between its messages."""
        due = [  # (forecast, step) pairs whose truth time has come
            (entry, k)
            for entry in self._pending
            for k in range(1, self.horizon + 1)
            if since < entry[0] + k * step <= now
        ]
        if not due:
            return
        # Every truth in one query: the observations are sorted once, not once per forecast.
        ids = np.concatenate([entry[1] for entry, _ in due])
        times = np.concatenate([np.full(len(entry[1]), entry[0] + k * step) for entry, k in due])
        xy, found = positions_at(ids, times)
        start = 0
        for (_, _, point, shapes, drawn), k in due:
            rows = slice(start, start + len(point))
            start += len(point)
            seen = found[rows]
            if seen.any():
                scores = distances_under(point[seen, k - 1], shapes[seen, k - 1], xy[rows][seen])
                self._update(k - 1, scores, drawn[:, k - 1])

    def _update(self, h: int, scores: np.ndarray, drawn: np.ndarray | None = None) -> None:
        """Move step ``h``'s radii by the (n,) scores, each against the (Q,) radii its region
        was drawn with (default: those in force)."""
        drawn = self.radii[:, h] if drawn is None else drawn
        missed = (scores[None, :] > drawn[:, None]).sum(axis=1)  # (Q,)
        self.scored[h] += len(scores)
        self.missed[:, h] += missed
        share = missed / len(scores) - (1.0 - self.qs)
        self.radii[:, h] = np.maximum(
            self.radii[:, h] + self.learning_rate * self.scale[h] * share, 0.0
        )

    def forget_pending(self) -> None:
        """Drop the forecasts still awaiting their truths (the session's clock jumped: their
        times no longer compare with the new ones)."""
        self._pending = []

    def save(self, path: str | Path) -> None:
        """Write the state (not the forecasts awaiting truths) as JSON."""
        document = {
            "format": FORMAT,
            "source": self.source,
            "learning_rate": self.learning_rate,
            "prior_samples": self.prior_samples,
            "q": [float(q) for q in self.qs],
            "radius_per_step": [[float(r) for r in row] for row in self.radii],  # exact: resumes
            "scale_per_step": [float(s) for s in self.scale],
            "scored_per_step": [int(n) for n in self.scored],
            "missed_per_step": [[int(n) for n in row] for row in self.missed],
        }
        write_text_atomically(Path(path), json.dumps(document, indent=1) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> OnlineCalibration:
        """Read a state written by :meth:`save` (one line if it is not one)."""
        with document_errors(path, "online state", "online calibration state"):
            document: dict[str, Any] = read_json_document(path, FORMAT)
            radii = np.asarray(document["radius_per_step"], dtype=np.float64)
            state = cls(
                qs=np.asarray(document["q"], dtype=np.float64),
                radii=radii,
                scale=np.asarray(document["scale_per_step"], dtype=np.float64),
                scored=np.asarray(document["scored_per_step"], dtype=np.int64),
                missed=np.asarray(document["missed_per_step"], dtype=np.int64),
                learning_rate=float(document["learning_rate"]),
                source=str(document.get("source", "")),
                prior_samples=int(document.get("prior_samples", 0)),
            )
            if (
                radii.ndim != 2
                or state.missed.shape != radii.shape
                or not all(math.isfinite(r) for r in radii.ravel())
            ):
                raise ValueError("radius_per_step and missed_per_step need one row per q")
            return state


def online_state(
    chosen: bool | str | Path | OnlineCalibration,
    horizon: int,
    calibration: RegionCalibration | None,
) -> OnlineCalibration | None:
    """A session's online calibration as ``Predictor(online_calibration=...)`` names it: True
    starts one from ``calibration`` (else the Gaussian radii), a saved state's file or an
    ``OnlineCalibration`` resumes it, False is none."""
    if isinstance(chosen, OnlineCalibration):
        return chosen
    if isinstance(chosen, str | Path):
        return OnlineCalibration.load(chosen)
    if chosen is True:
        return OnlineCalibration.start(horizon, calibration)
    if chosen is False:
        return None
    raise GrouptronError(
        f"online_calibration must be True, False, a saved state's file or an "
        f"OnlineCalibration, not {chosen!r}"
    )


@dataclass(frozen=True, eq=False)
class ForecastRadii:
    """Per forecast, the radii in force when it was made (a replay's): what regions take.

    Attributes:
        qs: (Q,) the probabilities kept.
        radii: (N, Q, H) radii per forecast, q and step.
    """

    qs: np.ndarray
    radii: np.ndarray

    def radius(self, q: float) -> np.ndarray:
        """(N, H) the radii at ``q`` (one of ``qs``)."""
        match = np.flatnonzero(np.isclose(self.qs, q))
        if not len(match):
            kept = ", ".join(f"{k:g}" for k in self.qs)
            raise GrouptronError(f"online radii were kept for q = {kept}, not {q}")
        radius: np.ndarray = self.radii[:, match[0]]
        return radius


def replay(
    state: OnlineCalibration,
    seen: tuple[np.ndarray, np.ndarray, np.ndarray],
    made: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    step: int,
    qs: tuple[float, ...],
) -> ForecastRadii:
    """A recording replayed in time order: at every frame the truths seen there are scored
    first, then the forecasts made there get the radii in force (strictly causal: a region
    at frame t uses only truths seen by t).

    Args:
        state: where the radii start; it ends as the replay leaves it.
        seen: the observations, (R,) frames, (R,) ids and (R, 2) positions.
        made: the forecasts, (N,) frames, (N,) ids, (N, H, 2) points, (N, H, 2, 2) shapes.
        step: frames per forecast step.
        qs: the probabilities whose radii are kept per forecast.
    """
    seen_frames, seen_ids, seen_xy = seen
    frames, ids, points, shapes = made
    kept = np.array([np.flatnonzero(np.isclose(state.qs, q))[0] for q in qs], dtype=np.int64)
    radii = np.zeros((len(frames), len(qs), state.horizon))
    seen_order, made_order = (
        np.argsort(seen_frames, kind="stable"),
        np.argsort(frames, kind="stable"),
    )
    seen_sorted, made_sorted = seen_frames[seen_order], frames[made_order]
    for frame in np.unique(np.concatenate([seen_frames, frames])):  # one pass per time step
        rows = seen_order[_span(seen_sorted, frame)]
        state.observe(int(frame), seen_ids[rows], seen_xy[rows], step)
        now = made_order[_span(made_sorted, frame)]
        if len(now):
            radii[now] = state.radii[kept][None]
            state.remember(int(frame), ids[now], points[now], shapes[now], step)
    return ForecastRadii(np.asarray(qs, dtype=np.float64), radii)


def _span(sorted_frames: np.ndarray, frame: float) -> slice:
    """The rows of ``frame`` in (R,) sorted frames."""
    first = int(np.searchsorted(sorted_frames, frame, "left"))
    return slice(first, int(np.searchsorted(sorted_frames, frame, "right")))
