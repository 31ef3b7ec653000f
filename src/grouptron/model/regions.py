"""Prediction regions: per forecast step, the ellipse around the point forecast that holds a
probability ``q`` of the forecast's Gaussian mixture.

The ellipse's shape is the mixture's second moment about the point forecast (its covariance
plus the spread of the component means around the forecast), and its size is chosen so that
the mixture's mass inside is ``q``. That mass has no closed form for a mixture; it is taken
over a fixed stratified lattice of each component (equal-probability rings of the standard
normal at evenly spaced angles), so the result is deterministic and exact for one Gaussian
centred on the forecast up to the lattice's resolution (tested against the chi-square
quantile).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grouptron.constants import MAX_REGION_Q
from grouptron.model.mixture import Mixture

POINTS = 128
"""Lattice points per component: point ``p`` holds ``(p + 0.5) / POINTS`` of the standard
normal's mass inside its radius, at an angle turned by the golden angle from the last."""
MAX_COVERAGE = MAX_REGION_Q
"""The largest ``q`` the lattice resolves (its outermost point holds 1 - 0.5 / POINTS)."""
CHUNK = 64
"""Forecasts per block: with 25 latent values a block's arrays are about 20 MB each."""


@dataclass(frozen=True, eq=False)
class Regions:
    """Ellipses holding probability ``q`` of each forecast's distribution, per step.

    Attributes:
        q: the probability each ellipse holds.
        centre: (N, H, 2) the point forecast (the ellipse's centre), metres.
        major_m, minor_m: (N, H) semi-axes, metres.
        angle_rad: (N, H) the major axis's angle from +x, in (-pi/2, pi/2].
    """

    q: float
    centre: np.ndarray
    major_m: np.ndarray
    minor_m: np.ndarray
    angle_rad: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N, H) whether each (N, H, 2) point lies inside its step's ellipse."""
        offset = points - self.centre
        cos, sin = np.cos(self.angle_rad), np.sin(self.angle_rad)
        along = cos * offset[..., 0] + sin * offset[..., 1]
        across = -sin * offset[..., 0] + cos * offset[..., 1]
        inside: np.ndarray = (along / self.major_m) ** 2 + (across / self.minor_m) ** 2 <= 1.0
        return inside


def standard_lattice() -> np.ndarray:
    """(POINTS, 2) points of equal probability under the 2-D standard normal, each at its own
    radius (so that, for one Gaussian centred on the forecast, the mass inside a point's radius
    is exactly its rank's share) and spread evenly over the angles."""
    mass = (np.arange(POINTS) + 0.5) / POINTS
    radius = np.sqrt(-2.0 * np.log1p(-mass))  # chi-square (2 dof) quantiles, square-rooted
    angle = np.arange(POINTS) * np.pi * (3.0 - np.sqrt(5.0))  # the golden angle apart
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], -1)


def _cholesky_2x2(cov: np.ndarray) -> np.ndarray:
    """(..., 2, 2) covariances -> (..., 3) lower Cholesky factors' entries (l00, l10, l11)."""
    l00 = np.sqrt(np.maximum(cov[..., 0, 0], 1e-300))
    l10 = cov[..., 1, 0] / l00
    l11 = np.sqrt(np.maximum(cov[..., 1, 1] - l10**2, 1e-300))
    return np.stack([l00, l10, l11], -1)


def _weights(log_weights: np.ndarray) -> np.ndarray:
    """(N, M) log weights of the components -> (N, M) weights summing to 1."""
    weights = np.exp(log_weights - log_weights.max(axis=1, keepdims=True))
    normalised: np.ndarray = weights / weights.sum(axis=1, keepdims=True)
    return normalised


def _shape_about(
    centre: np.ndarray, weights: np.ndarray, means: np.ndarray, covs: np.ndarray
) -> np.ndarray:
    """(N, H, 2, 2) second moment of each step's mixture about ``centre``.

    Args:
        centre: (N, H, 2); weights: (N, M) summing to 1; means: (N, M, H, 2);
            covs: (N, M, H, 2, 2).
    """
    offset = means - centre[:, None]  # (N, M, H, 2)
    spread = covs + offset[..., :, None] * offset[..., None, :]
    shape: np.ndarray = np.einsum("nm,nmhij->nhij", weights, spread)
    return shape


def _mass_radius(
    centre: np.ndarray,
    weights: np.ndarray,
    means: np.ndarray,
    covs: np.ndarray,
    shape: np.ndarray,
    q: float,
) -> np.ndarray:
    """(N, H) the Mahalanobis radius (under ``shape``) whose ellipse holds mass ``q``."""
    N, M, H, _ = means.shape
    lattice = standard_lattice().astype(np.float32)  # (P, 2); float32 halves the traffic
    P = len(lattice)
    # Whiten by the shape's Cholesky factor's inverse W: a component's lattice point
    # mu + L eps lands at W (mu - centre) + (W L) eps, and its distance is that point's length.
    s00, s10, s11 = np.moveaxis(_cholesky_2x2(shape), -1, 0)  # (N, H) each
    w00, w10, w11 = (w[:, None, :] for w in (1.0 / s00, -s10 / (s00 * s11), 1.0 / s11))
    l00, l10, l11 = np.moveaxis(_cholesky_2x2(covs), -1, 0)  # (N, M, H) each
    dx, dy = np.moveaxis(means - centre[:, None], -1, 0)  # (N, M, H) each
    # Whitened point = (a0 + a1 ex, b0 + b1 ex + b2 ey), per component and step.
    a0, a1 = w00 * dx, w00 * l00
    b0, b1, b2 = w10 * dx + w11 * dy, w10 * l00 + w11 * l10, w11 * l11
    ex, ey = lattice[:, 0], lattice[:, 1]
    f32 = [c.astype(np.float32)[..., None] for c in (a0, a1, b0, b1, b2)]  # (N, M, H, 1)
    x, y = f32[0] + f32[1] * ex, f32[2] + f32[3] * ex + f32[4] * ey  # (N, M, H, P)
    distance = (x * x + y * y).transpose(0, 2, 1, 3).reshape(N, H, M * P)  # squared
    order = np.argsort(distance, axis=-1)
    point_weight = (weights / P)[:, None, :]  # (N, 1, M): every point of a component alike
    sorted_weight = np.take_along_axis(point_weight, order // P, -1)  # (N, H, M * P)
    # Each lattice point stands for the mass around it: interpolate between the cumulative
    # masses at the points themselves (half of each point's own mass below it).
    midpoint = np.cumsum(sorted_weight, -1) - 0.5 * sorted_weight
    above = np.clip((midpoint < q).sum(-1), 1, M * P - 1)[..., None]  # first point past q
    bracket = np.concatenate([above - 1, above], -1)  # (N, H, 2)
    mass = np.take_along_axis(midpoint, bracket, -1)
    reach = np.sqrt(np.take_along_axis(distance, np.take_along_axis(order, bracket, -1), -1))
    share = np.clip((q - mass[..., 0]) / np.maximum(mass[..., 1] - mass[..., 0], 1e-300), 0, 1)
    radius: np.ndarray = reach[..., 0] + share * (reach[..., 1] - reach[..., 0])
    return radius


def ellipse_axes(shape: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, ...]:
    """(..., 2, 2) shapes and (...) radii -> semi-major, semi-minor (m) and angle (rad)."""
    sxx, sxy, syy = shape[..., 0, 0], shape[..., 0, 1], shape[..., 1, 1]
    half_trace, half_gap = 0.5 * (sxx + syy), np.sqrt((0.5 * (sxx - syy)) ** 2 + sxy**2)
    major = radius * np.sqrt(np.maximum(half_trace + half_gap, 0.0))
    minor = radius * np.sqrt(np.maximum(half_trace - half_gap, 0.0))
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # in (-pi/2, pi/2]
    return major, minor, angle


def prediction_regions(centre: np.ndarray, mixture: Mixture, q: float) -> Regions:
    """Per forecast and step, the ellipse around ``centre`` holding mass ``q`` of the mixture.

    Args:
        centre: (N, H, 2) point forecasts.
        mixture: the distribution each was made from (N people, M components).
        q: the probability each ellipse holds, in (0, MAX_COVERAGE].
    """
    weights = _weights(mixture.log_weights)
    parts = []
    for start in range(0, len(centre), CHUNK):
        block = slice(start, start + CHUNK)
        c, w = centre[block], weights[block]
        mu, cov = mixture.means[block], mixture.covariances[block]
        shape = _shape_about(c, w, mu, cov)
        parts.append(ellipse_axes(shape, _mass_radius(c, w, mu, cov, shape, q)))
    if not parts:
        empty = np.zeros(centre.shape[:2])
        return Regions(q, centre, empty, empty.copy(), empty.copy())
    major, minor, angle = (np.concatenate(part) for part in zip(*parts, strict=True))
    return Regions(q, centre, major, minor, angle)


def region_shapes(centre: np.ndarray, mixture: Mixture) -> np.ndarray:
    """(N, H, 2, 2) each step's region shape: the mixture's second moment about ``centre``
    (its covariance plus the spread of the component means around the forecast)."""
    return _shape_about(centre, _weights(mixture.log_weights), mixture.means, mixture.covariances)


def shape_distances(centre: np.ndarray, mixture: Mixture, points: np.ndarray) -> np.ndarray:
    """(N, H) each (N, H, 2) point's Mahalanobis distance from the point forecast under its
    region's shape (the score a calibration ranks): a point is inside the region of radius r
    when this is at most r."""
    return distances_under(centre, region_shapes(centre, mixture), points)


def distances_under(centre: np.ndarray, shapes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(...) each (..., 2) point's Mahalanobis distance from its (..., 2) centre under its
    (..., 2, 2) region shape."""
    offset = points - centre
    solved = np.linalg.solve(shapes, offset[..., None])[..., 0]
    distance: np.ndarray = np.sqrt(np.maximum((offset * solved).sum(-1), 0.0))
    return distance


def conformal_radii(scores: np.ndarray, qs: np.ndarray) -> np.ndarray:
    """Split-conformal radii: (n, H) calibration scores -> (Q, H) radii, per step the
    ceil((n + 1) q)-th smallest score (infinite where that exceeds n). For a new sample
    exchangeable with the calibration ones, its score is at most that radius with
    probability at least q (Vovk et al. 2005; Lei et al. 2018)."""
    n = len(scores)
    ranked = np.sort(scores, axis=0)  # (n, H)
    rank = np.ceil((n + 1) * qs - 1e-9).astype(np.int64)  # 1-based; float error never adds one
    radii = np.full((len(qs), scores.shape[1]), np.inf)
    finite = rank <= n
    radii[finite] = ranked[rank[finite] - 1]
    return radii


def calibrated_regions(
    centre: np.ndarray, mixture: Mixture, q: float, radius: np.ndarray
) -> Regions:
    """Regions of the same shape as :func:`prediction_regions`', of the (H,) calibrated
    ``radius`` per step instead of the mixture's own."""
    shape = region_shapes(centre, mixture)
    major, minor, angle = ellipse_axes(shape, np.broadcast_to(radius, shape.shape[:2]))
    return Regions(q, centre, major, minor, angle)
