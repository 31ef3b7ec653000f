"""Which prediction regions an evaluation scores, and their per-step scores.

A point forecast's regions (``model.regions``: per step the ellipse around the forecast that
holds probability ``q`` of the distribution it was made from) are scored by every registered
region metric (:data:`grouptron.evaluation.metrics.REGION_METRICS`): coverage and area per
sample and step. The model's own regions by default; with calibrated radii (a calibration
file's, read where the layers allow: ``workflows.evaluate``), those of the same shape and the
site's size.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from grouptron.constants import MAX_REGION_Q
from grouptron.evaluation import metrics
from grouptron.model.mixture import Mixture
from grouptron.model.regions import calibrated_regions, prediction_regions


@dataclass(frozen=True, eq=False)
class RegionScoring:
    """The prediction regions to score.

    Attributes:
        qs: the probabilities the regions hold, each in (0, MAX_REGION_Q], each once.
        radii: per q, the (H,) calibrated radius of each step (a calibration file's); empty:
            the model's own regions.
    """

    qs: tuple[float, ...]
    radii: Mapping[float, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        qs = tuple(dict.fromkeys(float(q) for q in self.qs))
        if not qs or any(not 0.0 < q <= MAX_REGION_Q for q in qs):
            raise ValueError(f"region probabilities must be in (0, {MAX_REGION_Q}]: {self.qs}")
        missing = [q for q in qs if self.radii and q not in self.radii]
        if missing:
            raise ValueError(f"calibrated radii lack q = {missing}")
        object.__setattr__(self, "qs", qs)

    @property
    def calibrated(self) -> bool:
        """Whether the regions take calibrated radii (else the model's own)."""
        return bool(self.radii)

    @property
    def names(self) -> tuple[str, ...]:
        """The region metrics' keys (``coverage-q90``, ``area-q90``, ...)."""
        return metrics.region_metric_names(self.qs)

    def key(self) -> str:
        """What the scores depend on besides the forecast, as text (for the score cache)."""
        digest = hashlib.sha256(repr(self.qs).encode())
        for q in self.qs if self.calibrated else ():
            digest.update(np.ascontiguousarray(self.radii[q], dtype=np.float64).tobytes())
        kind = "calibrated" if self.calibrated else "own"
        return f"regions:{kind}:{digest.hexdigest()[:16]}"

    def scores(
        self, point: np.ndarray, distribution: Mixture, truth: np.ndarray
    ) -> dict[str, np.ndarray]:
        """Every region metric at every q: name -> (B, H).

        Args:
            point: (B, H, 2) point forecasts relative to the position now, metres.
            distribution: the mixture each was made from, relative to the same origin.
            truth: (B, H, 2) true positions, relative to the same origin.
        """
        found: dict[str, np.ndarray] = {}
        for q in self.qs:
            if self.calibrated:
                regions = calibrated_regions(point, distribution, q, self.radii[q])
            else:
                regions = prediction_regions(point, distribution, q)
            found.update(metrics.region_scores(regions, truth))
        return found
