"""The mode of a 2-D Gaussian mixture, by a vectorised fixed-point iteration.

The reference searches a 1 cm grid spanning the component means (seconds per pedestrian).
Here every mixture starts from its most promising component means and climbs the log-density:
the mode-finding fixed point ``x <- (sum_k r_k(x) P_k)^-1 sum_k r_k(x) P_k mu_k`` (``P_k`` the
precision matrices, ``r_k`` the responsibilities; it never descends, Carreira-Perpinan 2000)
or, where it climbs higher, a Newton step. The best end point wins. Float64 throughout, in
NumPy: a live update climbs a few thousand small mixtures, where each array operation's fixed
cost, not its arithmetic, sets the time, and NumPy's is a fraction of PyTorch's.

Arrays are laid out entry-first and mixture-last: a mixture's Z components lie along the
leading axis and each coordinate or matrix entry is an array of its own, ``mean`` (2, Z, R),
``precision`` (3, Z, R), ``log_norm`` (Z, R) for R mixtures. Sums over components are then
whole-row additions and every operation runs over contiguous memory; with the live forecast's
two components a reduction over a trailing axis of length 2 cost more than the arithmetic.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch

from grouptron.model import gaussians

PARALLEL_MIN_BLOCK_VALUES = 32768
"""Worker threads climb the blocks only when a block's arrays hold at least this many values
(mixtures x components x starts): NumPy frees the interpreter inside each operation, but on
smaller arrays handing it between threads costs more than the second core gives. A live
update's ``ml-top2`` (at most 2048 x 2 x 1 per block) and ``ml-top10`` (20,480) climb on the
calling thread, the benchmark's ``ml`` (25 components, 4 starts) on workers
(``benchmarks/mixture_mode.py``)."""


def _logsumexp(values: np.ndarray, axis: int = 0) -> np.ndarray:
    """Log of the sum of exponentials over ``axis`` (the components')."""
    top = values.max(axis=axis)
    shifted = values - np.expand_dims(top, axis)
    total: np.ndarray = top + np.log(np.exp(shifted).sum(axis=axis))
    return total


def _precision(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(3, ...) covariance entries -> (3, ...) precision entries and (...) log-determinants."""
    var_x, cov_xy, var_y = cov
    det = var_x * var_y - cov_xy**2
    return np.stack([var_y, -cov_xy, var_x]) / det, np.log(det)


def _quad(dx: np.ndarray, dy: np.ndarray, precision: np.ndarray) -> np.ndarray:
    """(...) vector entries, (3, ...) precision entries -> (...) quadratic forms."""
    quad: np.ndarray = precision[0] * dx**2 + 2.0 * precision[1] * dx * dy + precision[2] * dy**2
    return quad


def _log_components(
    points: np.ndarray, log_norm: np.ndarray, mean: np.ndarray, precision: np.ndarray
) -> np.ndarray:
    """(2, R) points of R mixtures -> (Z, R) log of weight * component density."""
    return log_norm - 0.5 * _quad(points[0] - mean[0], points[1] - mean[1], precision)


def _solve(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(3, R) symmetric 2x2 matrices (xx, xy, yy), (2, R) vectors -> (2, R) ``a^-1 v``."""
    det = a[0] * a[2] - a[1] ** 2
    solved: np.ndarray = np.stack([a[2] * v[0] - a[1] * v[1], a[0] * v[1] - a[1] * v[0]]) / det
    return solved


def _columns(values: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """(..., R) values, (R,) booleans -> (..., K) the kept mixtures' columns, contiguous (plain
    indexing of the last axis gives a strided array, and every later operation pays for it)."""
    kept: np.ndarray = np.compress(keep, values, axis=-1)
    return kept


def _weighted(resp: np.ndarray, entries: np.ndarray) -> np.ndarray:
    """(Z, R) responsibilities, (C, Z, R) entries -> (C, R) their responsibility-weighted sum."""
    weighted: np.ndarray = (resp * entries).sum(axis=1)
    return weighted


def _newton_or_fixed_point(
    x: np.ndarray,
    lc: np.ndarray,
    ln: np.ndarray,
    mu: np.ndarray,
    prec: np.ndarray,
    pm: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One safeguarded step from (2, A) points with (Z, A) log components: Newton's where the
    Hessian is negative definite and the density rises, else the fixed point ``A^-1 b``
    (which never descends). Returns the new points and their log components."""
    f = _logsumexp(lc)
    resp = np.exp(lc - f)  # (Z, A)
    a = _weighted(resp, prec)  # (3, A)
    b = _weighted(resp, pm)  # (2, A)
    # grad l_k = P_k (mu_k - x) = pm_k - P_k x; grad f = sum_k r_k grad l_k = b - A x
    g0 = pm[0] - (prec[0] * x[0] + prec[1] * x[1])  # (Z, A)
    g1 = pm[1] - (prec[1] * x[0] + prec[2] * x[1])
    grad = b - np.stack([a[0] * x[0] + a[1] * x[1], a[1] * x[0] + a[2] * x[1]])  # (2, A)
    hessian = _weighted(resp, np.stack([g0**2, g0 * g1, g1**2])) - a
    hessian -= np.stack([grad[0] ** 2, grad[0] * grad[1], grad[1] ** 2])
    concave = (hessian[0] < 0) & (hessian[0] * hessian[2] - hessian[1] ** 2 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):  # non-concave rows are discarded
        newton = x - _solve(hessian, grad)
    newton = np.where(concave, newton, x)
    lc_newton = _log_components(newton, ln, mu, prec)
    fallback = ~(concave & (_logsumexp(lc_newton) > f))
    if fallback.any():
        fixed_point = _solve(*(_columns(v, fallback) for v in (a, b)))
        newton[:, fallback] = fixed_point
        lc_newton[:, fallback] = _log_components(
            fixed_point, *(_columns(v, fallback) for v in (ln, mu, prec))
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
        points: (2, R) starts; log_norm: (Z, R); mean: (2, Z, R); precision: (3, Z, R);
            prec_mean: (2, Z, R) ``P_k mu_k``.

    Returns:
        (2, R) end points and (R,) their log-densities.
    """
    points = points.copy()
    log_comp = _log_components(points, log_norm, mean, precision)  # (Z, R)
    # The moving points' columns, kept contiguous and cut only when some stop: most climbs
    # move every point for the first iterations.
    active = np.arange(points.shape[1])
    arrays: tuple[np.ndarray, ...] = (log_norm, mean, precision, prec_mean)
    x, lc = points, log_comp
    for _ in range(max_iters):
        new_x, new_lc = _newton_or_fixed_point(x, lc, *arrays)
        moving = np.abs(new_x - x).max(axis=0) >= tol
        x, lc = new_x, new_lc
        if moving.all():
            continue
        stopped = active[~moving]
        points[:, stopped], log_comp[:, stopped] = x[:, ~moving], lc[:, ~moving]
        active = active[moving]
        if len(active) == 0:
            break
        x, lc = _columns(x, moving), _columns(lc, moving)
        arrays = tuple(_columns(a, moving) for a in arrays)
    else:  # some still moving after max_iters
        points[:, active], log_comp[:, active] = x, lc
    return points, _logsumexp(log_comp)


def _separated_starts(
    at_means: np.ndarray, mean: np.ndarray, count: int, min_gap: float = 0.05
) -> np.ndarray:
    """Pick ``count`` component means per mixture, highest density first, skipping means
    within ``min_gap`` of one already picked (they would climb to the same peak).

    Args:
        at_means: (Z, N) mixture log-density at every component mean.
        mean: (2, Z, N).

    Returns:
        (count, N) component indices (repeats when fewer distinct means exist).
    """
    score = at_means.copy()
    columns = np.arange(score.shape[1])
    picked = []
    for _ in range(count):  # a handful of rounds, vectorised over mixtures
        best = score.argmax(axis=0)  # (N,)
        picked.append(best)
        if len(picked) == count:
            break
        dx, dy = mean[0] - mean[0, best, columns], mean[1] - mean[1, best, columns]
        score[np.sqrt(dx**2 + dy**2) < min_gap] = -np.inf
        exhausted = np.isinf(score).all(axis=0)
        score[:, exhausted] = at_means[:, exhausted]
    return np.stack(picked)


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
        few thousand 2-D mixtures are too small for an accelerator to pay off).
    """
    weights_zn = np.ascontiguousarray(log_weights.detach().cpu().double().numpy().T)  # (Z, N)
    mean_czn, cov_czn = (
        np.ascontiguousarray(t.detach().cpu().double().numpy().transpose(2, 1, 0))
        for t in (mean, cov)
    )  # (2, Z, N), (3, Z, N)
    count = weights_zn.shape[1]
    size = max(1, -(-count // max(1, -(-count // chunk))))  # equal blocks of at most ``chunk``

    def block(start: int) -> np.ndarray:
        part = slice(start, start + size)
        return _mixture_mode_block(
            weights_zn[:, part],
            mean_czn[..., part],
            cov_czn[..., part],
            num_starts,
            max_iters=max_iters,
            tol=tol,
        )

    starts = range(0, count, size)
    workers = min(torch.get_num_threads(), len(starts))
    block_values = size * weights_zn.shape[0] * min(num_starts, weights_zn.shape[0])
    if workers > 1 and block_values >= PARALLEL_MIN_BLOCK_VALUES:
        with ThreadPoolExecutor(workers) as pool:
            modes = list(pool.map(block, starts))
    else:
        modes = [block(start) for start in starts]
    modes_2n = np.concatenate(modes, axis=1) if modes else np.zeros((2, 0))
    return torch.from_numpy(np.ascontiguousarray(modes_2n.T)).to(mean.device)


def _mixture_mode_block(
    log_weights: np.ndarray,
    mean: np.ndarray,
    cov: np.ndarray,
    num_starts: int,
    *,
    max_iters: int,
    tol: float,
) -> np.ndarray:
    """(Z, N) log weights, (2, Z, N) means, (3, Z, N) covariances -> (2, N) modes."""
    Z, N = log_weights.shape
    precision, log_det = _precision(cov)  # (3, Z, N), (Z, N)
    log_norm = log_weights - math.log(2.0 * math.pi) - 0.5 * log_det  # (Z, N)
    prec_mean = np.stack(
        [
            precision[0] * mean[0] + precision[1] * mean[1],
            precision[1] * mean[0] + precision[2] * mean[1],
        ]
    )  # (2, Z, N)

    # Density of each mixture at each of its own component means: (Z_at, Z_comp, N) in one go.
    dx, dy = (m[:, None] - m[None] for m in mean)
    at_means = _logsumexp(log_norm[None] - 0.5 * _quad(dx, dy, precision[:, None]), axis=1)
    S = min(num_starts, Z)
    starts = _separated_starts(at_means, mean, S)  # (S, N)
    columns = np.arange(N)
    points = np.stack([mean[0, starts, columns], mean[1, starts, columns]]).reshape(2, S * N)
    owned: tuple[np.ndarray, ...] = (log_norm, mean, precision, prec_mean)
    if S > 1:  # start s of mixture n is column s * N + n
        owner = np.tile(columns, S)
        owned = tuple(np.take(a, owner, axis=-1) for a in owned)
    points, score = _climb(points, *owned[:3], prec_mean=owned[3], max_iters=max_iters, tol=tol)
    best = score.reshape(S, N).argmax(axis=0)
    modes: np.ndarray = points.reshape(2, S, N)[:, best, columns]
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
