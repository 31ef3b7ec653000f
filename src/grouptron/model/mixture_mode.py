"""The mode of a 2-D Gaussian mixture, by a vectorised fixed-point iteration.

The reference searches a 1 cm grid spanning the component means (seconds per pedestrian).
Here every mixture starts from its most promising component means and climbs the log-density:
the mode-finding fixed point ``x <- (sum_k r_k(x) P_k)^-1 sum_k r_k(x) P_k mu_k`` (``P_k`` the
precision matrices, ``r_k`` the responsibilities; it never descends, Carreira-Perpinan 2000)
or, where it climbs higher, a Newton step. The best end point wins. Float64 throughout, in
NumPy: a live update climbs a few hundred small mixtures, where each array operation's fixed
cost, not its arithmetic, sets the time, and NumPy's is a fraction of PyTorch's.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch

from grouptron.model import gaussians


def _logsumexp(values: np.ndarray) -> np.ndarray:
    """(..., Z) -> (...) log of the sum of exponentials over the last axis."""
    top = values.max(axis=-1)
    total: np.ndarray = top + np.log(np.exp(values - top[..., None]).sum(axis=-1))
    return total


def _precision(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(..., 3) covariance entries -> (..., 3) precision entries and (...) log-determinants."""
    var_x, cov_xy, var_y = cov[..., 0], cov[..., 1], cov[..., 2]
    det = var_x * var_y - cov_xy**2
    return np.stack([var_y, -cov_xy, var_x], -1) / det[..., None], np.log(det)


def _quad(diff: np.ndarray, precision: np.ndarray) -> np.ndarray:
    """(..., 2) vectors, (..., 3) precision entries -> (...) quadratic forms."""
    dx, dy = diff[..., 0], diff[..., 1]
    quad: np.ndarray = (
        precision[..., 0] * dx**2 + 2.0 * precision[..., 1] * dx * dy + precision[..., 2] * dy**2
    )
    return quad


def _log_components(
    points: np.ndarray, log_norm: np.ndarray, mean: np.ndarray, precision: np.ndarray
) -> np.ndarray:
    """(R, 2) points of R mixtures -> (R, Z) log of weight * component density."""
    return log_norm - 0.5 * _quad(points[:, None, :] - mean, precision)


def _solve(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(R, 3) symmetric 2x2 matrices (xx, xy, yy), (R, 2) vectors -> (R, 2) ``a^-1 v``."""
    det = a[:, 0] * a[:, 2] - a[:, 1] ** 2
    adjugate_v = np.stack(
        [a[:, 2] * v[:, 0] - a[:, 1] * v[:, 1], a[:, 0] * v[:, 1] - a[:, 1] * v[:, 0]], -1
    )
    solved: np.ndarray = adjugate_v / det[:, None]
    return solved


def _weighted(resp: np.ndarray, entries: np.ndarray) -> np.ndarray:
    """(R, Z) responsibilities, (R, Z, C) entries -> (R, C) their responsibility-weighted sum."""
    weighted: np.ndarray = np.einsum("rz,rzc->rc", resp, entries)
    return weighted


def _newton_or_fixed_point(
    x: np.ndarray,
    lc: np.ndarray,
    ln: np.ndarray,
    mu: np.ndarray,
    prec: np.ndarray,
    pm: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One safeguarded step from (A, 2) points with (A, Z) log components: Newton's where the
    Hessian is negative definite and the density rises, else the fixed point ``A^-1 b``
    (which never descends). Returns the new points and their log components."""
    f = _logsumexp(lc)
    resp = np.exp(lc - f[:, None])  # (A, Z)
    a = _weighted(resp, prec)  # (A, 3)
    b = _weighted(resp, pm)  # (A, 2)
    # grad l_k = P_k (mu_k - x) = pm_k - P_k x; grad f = sum_k r_k grad l_k = b - A x
    x0, x1 = x[:, None, 0], x[:, None, 1]
    grad_k = pm - np.stack(
        [prec[..., 0] * x0 + prec[..., 1] * x1, prec[..., 1] * x0 + prec[..., 2] * x1], -1
    )  # (A, Z, 2)
    grad = b - np.stack(
        [a[:, 0] * x[:, 0] + a[:, 1] * x[:, 1], a[:, 1] * x[:, 0] + a[:, 2] * x[:, 1]], -1
    )
    g0, g1 = grad_k[..., 0], grad_k[..., 1]
    hessian = _weighted(resp, np.stack([g0**2, g0 * g1, g1**2], -1)) - a
    hessian -= np.stack([grad[:, 0] ** 2, grad[:, 0] * grad[:, 1], grad[:, 1] ** 2], -1)
    concave = (hessian[:, 0] < 0) & (hessian[:, 0] * hessian[:, 2] - hessian[:, 1] ** 2 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):  # non-concave rows are discarded
        newton = x - _solve(hessian, grad)
    newton = np.where(concave[:, None], newton, x)
    lc_newton = _log_components(newton, ln, mu, prec)
    fallback = ~(concave & (_logsumexp(lc_newton) > f))
    if fallback.any():
        fixed_point = _solve(a[fallback], b[fallback])
        newton[fallback] = fixed_point
        lc_newton[fallback] = _log_components(
            fixed_point, ln[fallback], mu[fallback], prec[fallback]
        )
    return newton, lc_newton


def _climb(
    points: np.ndarray,
    log_norm: np.ndarray,
    mean: np.ndarray,
    precision: np.ndarray,
    *,
    prec_mean: np.ndarray,
    max_iters: int,
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Climb R points to local maxima of their mixtures' log-density; only points that still
    move are computed.

    Args:
        points: (R, 2) starts; log_norm: (R, Z); mean: (R, Z, 2); precision: (R, Z, 3);
            prec_mean: (R, Z, 2) ``P_k mu_k``.

    Returns:
        (R, 2) end points and (R,) their log-densities.
    """
    points = points.copy()
    log_comp = _log_components(points, log_norm, mean, precision)  # (R, Z)
    active = np.arange(len(points))
    for _ in range(max_iters):
        x = points[active]
        new_x, new_lc = _newton_or_fixed_point(
            x,
            log_comp[active],
            log_norm[active],
            mean[active],
            precision[active],
            prec_mean[active],
        )
        moved = np.abs(new_x - x).max(axis=-1)
        points[active] = new_x
        log_comp[active] = new_lc
        active = active[moved >= tol]
        if len(active) == 0:
            break
    return points, _logsumexp(log_comp)


def _separated_starts(
    at_means: np.ndarray, mean: np.ndarray, count: int, min_gap: float = 0.05
) -> np.ndarray:
    """Pick ``count`` component means per mixture, highest density first, skipping means
    within ``min_gap`` of one already picked (they would climb to the same peak).

    Args:
        at_means: (N, Z) mixture log-density at every component mean.
        mean: (N, Z, 2).

    Returns:
        (N, count) component indices (repeats when fewer distinct means exist).
    """
    score = at_means.copy()
    rows = np.arange(len(mean))
    picked = []
    for _ in range(count):  # a handful of rounds, vectorised over mixtures
        best = score.argmax(axis=-1)  # (N,)
        picked.append(best)
        if len(picked) == count:
            break
        near = np.linalg.norm(mean - mean[rows, best][:, None], axis=-1) < min_gap  # (N, Z)
        score[near] = -np.inf
        exhausted = np.isinf(score).all(axis=-1)
        score[exhausted] = at_means[exhausted]
    return np.stack(picked, axis=-1)


def mixture_mode(
    log_weights: torch.Tensor,
    mean: torch.Tensor,
    cov: torch.Tensor,
    num_starts: int = 4,
    *,
    max_iters: int = 30,
    tol: float = 1e-6,
    chunk: int = 2048,
) -> torch.Tensor:
    """Highest-density point of each mixture.

    Args:
        log_weights: (N, Z) log mixture weights (need not be normalised).
        mean: (N, Z, 2) component means.
        cov: (N, Z, 3) covariance entries (var_x, cov_xy, var_y).
        num_starts: iterate from the component means with the highest mixture density.
        max_iters: iteration cap.
        tol: a point stops once it moves less than this (metres or m/s).
        chunk: mixtures per block (blocks keep the temporaries in cache).

    Returns:
        (N, 2) float64 modes, on the device of ``mean`` (the climb itself runs on the CPU: a
        few hundred 2-D mixtures are too small for an accelerator to pay off).
    """
    arrays = [t.detach().cpu().double().numpy() for t in (log_weights, mean, cov)]

    count = len(arrays[0])
    size = -(-count // max(1, -(-count // chunk)))  # equal blocks of at most ``chunk``

    def block(start: int) -> np.ndarray:
        weights, means, covs = (a[start : start + size] for a in arrays)
        return _mixture_mode_block(weights, means, covs, num_starts, max_iters=max_iters, tol=tol)

    starts = range(0, count, max(size, 1))
    workers = min(torch.get_num_threads(), len(starts))
    if workers > 1:  # NumPy frees the interpreter inside its loops over large blocks
        with ThreadPoolExecutor(workers) as pool:
            modes = list(pool.map(block, starts))
    else:
        modes = [block(start) for start in starts]
    return torch.from_numpy(np.concatenate(modes) if modes else np.zeros((0, 2))).to(mean.device)


def _mixture_mode_block(
    log_weights: np.ndarray,
    mean: np.ndarray,
    cov: np.ndarray,
    num_starts: int,
    *,
    max_iters: int,
    tol: float,
) -> np.ndarray:
    N, Z = log_weights.shape
    precision, log_det = _precision(cov)  # (N, Z, 3), (N, Z)
    log_norm = log_weights - math.log(2.0 * math.pi) - 0.5 * log_det  # (N, Z)
    prec_mean = np.stack(
        [
            precision[..., 0] * mean[..., 0] + precision[..., 1] * mean[..., 1],
            precision[..., 1] * mean[..., 0] + precision[..., 2] * mean[..., 1],
        ],
        -1,
    )  # (N, Z, 2)

    # Density of each mixture at each of its own component means: (N, Z, Z) in one go.
    diff = mean[:, :, None, :] - mean[:, None, :, :]  # (N, Z_at, Z_comp, 2)
    at_means = _logsumexp(log_norm[:, None] - 0.5 * _quad(diff, precision[:, None]))
    S = min(num_starts, Z)
    starts = _separated_starts(at_means, mean, S)  # (N, S)
    owner = np.repeat(np.arange(N), S)  # mixture of each start
    points = np.take_along_axis(mean, starts[..., None], axis=1).reshape(N * S, 2)
    points, score = _climb(
        points,
        log_norm[owner],
        mean[owner],
        precision[owner],
        prec_mean=prec_mean[owner],
        max_iters=max_iters,
        tol=tol,
    )
    best = score.reshape(N, S).argmax(axis=-1)
    modes: np.ndarray = points.reshape(N, S, 2)[np.arange(N), best]
    return modes


def grid_mode(
    log_weights: torch.Tensor, mean: torch.Tensor, cov: torch.Tensor, resolution: float = 0.01
) -> torch.Tensor:
    """The reference's answer for one mixture: the best point of a grid over the means' box.

    Args:
        log_weights: (Z,); mean: (Z, 2); cov: (Z, 3).
        resolution: grid spacing (the reference uses 0.01).

    Returns:
        (2,) the best grid point.
    """
    lo, hi = mean.min(dim=0).values, mean.max(dim=0).values
    xs = torch.arange(float(lo[0]), float(hi[0]) + resolution, resolution, dtype=torch.float64)
    ys = torch.arange(float(lo[1]), float(hi[1]) + resolution, resolution, dtype=torch.float64)
    grid = torch.stack(torch.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    log_density = gaussians.mixture_log_prob(
        grid[:, None, :].expand(-1, 1, 2)[:, 0],
        torch.log_softmax(log_weights.double(), -1).expand(len(grid), -1),
        mean.double().expand(len(grid), -1, -1),
        cov.double().expand(len(grid), -1, -1),
    )
    return grid[log_density.argmax()]
