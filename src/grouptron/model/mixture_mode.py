"""The mode of a 2-D Gaussian mixture, by a vectorised fixed-point iteration.

The reference searches a 1 cm grid spanning the component means (seconds per pedestrian).
Here every mixture starts from its most promising component means and climbs the log-density:
the mode-finding fixed point ``x <- (sum_k r_k(x) P_k)^-1 sum_k r_k(x) P_k mu_k`` (``P_k`` the
precision matrices, ``r_k`` the responsibilities; it never descends, Carreira-Perpinan 2000)
or, where it climbs higher, a Newton step. The best end point wins. Float64 throughout.
"""

from __future__ import annotations

import math

import torch

from grouptron.model import gaussians


def _precision(cov: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(..., 3) covariance entries -> (..., 3) precision entries and (...) log-determinants."""
    var_x, cov_xy, var_y = cov.unbind(-1)
    det = var_x * var_y - cov_xy**2
    return torch.stack([var_y, -cov_xy, var_x], -1) / det[..., None], torch.log(det)


def _quad(diff: torch.Tensor, precision: torch.Tensor) -> torch.Tensor:
    """(..., 2) vectors, (..., 3) precision entries -> (...) quadratic forms."""
    dx, dy = diff.unbind(-1)
    p_xx, p_xy, p_yy = precision.unbind(-1)
    return p_xx * dx**2 + 2.0 * p_xy * dx * dy + p_yy * dy**2


def _log_components(
    points: torch.Tensor, log_norm: torch.Tensor, mean: torch.Tensor, precision: torch.Tensor
) -> torch.Tensor:
    """(R, 2) points of R mixtures -> (R, Z) log of weight * component density."""
    return log_norm - 0.5 * _quad(points[:, None, :] - mean, precision)


def _solve(a: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """(R, 3) symmetric 2x2 matrices (xx, xy, yy), (R, 2) vectors -> (R, 2) ``a^-1 v``."""
    det = a[:, 0] * a[:, 2] - a[:, 1] ** 2
    return (
        torch.stack(
            [a[:, 2] * v[:, 0] - a[:, 1] * v[:, 1], a[:, 0] * v[:, 1] - a[:, 1] * v[:, 0]], -1
        )
        / det[:, None]
    )


# Longer than 60 lines on purpose: one safeguarded Newton iteration whose active set, step
# choice and acceptance test share their intermediate tensors; split, each helper would take
# and return most of them.
def _climb(
    points: torch.Tensor,
    log_norm: torch.Tensor,
    mean: torch.Tensor,
    precision: torch.Tensor,
    *,
    prec_mean: torch.Tensor,
    max_iters: int,
    tol: float,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Climb R points to local maxima of their mixtures' log-density.

    Each step tries Newton's step (quadratic convergence near a peak) and keeps it where the
    Hessian is negative definite and the density rises; elsewhere it takes the fixed-point step
    ``A^-1 b`` (``A = sum_k r_k P_k``, ``b = sum_k r_k P_k mu_k``), which never descends.
    Only points that still move are computed.

    Args:
        points: (R, 2) starts; log_norm: (R, Z); mean: (R, Z, 2); precision: (R, Z, 3);
            prec_mean: (R, Z, 2) ``P_k mu_k``.

    Returns:
        (R, 2) end points and (R,) their log-densities.
    """
    points = points.clone()
    log_comp = _log_components(points, log_norm, mean, precision)  # (R, Z)
    active = torch.arange(len(points), device=points.device)
    for _ in range(max_iters):
        x, lc = points[active], log_comp[active]
        ln, mu, prec, pm = log_norm[active], mean[active], precision[active], prec_mean[active]
        f = torch.logsumexp(lc, -1)
        resp = torch.exp(lc - f[:, None])  # (A, Z)
        a = torch.einsum("rz,rzc->rc", resp, prec)  # (A, 3)
        b = torch.einsum("rz,rzc->rc", resp, pm)  # (A, 2)
        # grad l_k = P_k (mu_k - x) = pm_k - P_k x; grad f = sum_k r_k grad l_k = b - A x
        px = torch.stack(
            [
                prec[..., 0] * x[:, None, 0] + prec[..., 1] * x[:, None, 1],
                prec[..., 1] * x[:, None, 0] + prec[..., 2] * x[:, None, 1],
            ],
            -1,
        )
        grad_k = pm - px  # (A, Z, 2)
        grad = b - torch.stack(
            [a[:, 0] * x[:, 0] + a[:, 1] * x[:, 1], a[:, 1] * x[:, 0] + a[:, 2] * x[:, 1]], -1
        )
        outer = torch.stack(
            [grad_k[..., 0] ** 2, grad_k[..., 0] * grad_k[..., 1], grad_k[..., 1] ** 2], -1
        )
        hessian = torch.einsum("rz,rzc->rc", resp, outer) - a
        hessian = hessian - torch.stack(
            [grad[:, 0] ** 2, grad[:, 0] * grad[:, 1], grad[:, 1] ** 2], -1
        )
        concave = (hessian[:, 0] < 0) & (hessian[:, 0] * hessian[:, 2] - hessian[:, 1] ** 2 > 0)
        newton = x - _solve(hessian, grad)
        newton = torch.where(concave[:, None], newton, x)
        lc_newton = _log_components(newton, ln, mu, prec)
        take_newton = concave & (torch.logsumexp(lc_newton, -1) > f)

        new_x = newton
        new_lc = lc_newton
        fallback = ~take_newton
        if fallback.any():
            fixed_point = _solve(a[fallback], b[fallback])
            new_x = new_x.clone()
            new_x[fallback] = fixed_point
            new_lc = new_lc.clone()
            new_lc[fallback] = _log_components(
                fixed_point, ln[fallback], mu[fallback], prec[fallback]
            )
        moved = (new_x - x).abs().amax(dim=-1)
        points[active] = new_x
        log_comp[active] = new_lc
        active = active[moved >= tol]
        if len(active) == 0:
            break
    return points, torch.logsumexp(log_comp, -1)


def _separated_starts(
    at_means: torch.Tensor, mean: torch.Tensor, count: int, min_gap: float = 0.05
) -> torch.Tensor:
    """Pick ``count`` component means per mixture, highest density first, skipping means
    within ``min_gap`` of one already picked (they would climb to the same peak).

    Args:
        at_means: (N, Z) mixture log-density at every component mean.
        mean: (N, Z, 2).

    Returns:
        (N, count) component indices (repeats when fewer distinct means exist).
    """
    score = at_means.clone()
    picked = []
    for _ in range(count):  # a handful of rounds, vectorised over mixtures
        best = score.argmax(dim=-1)  # (N,)
        picked.append(best)
        chosen = mean[torch.arange(len(mean), device=mean.device), best]  # (N, 2)
        near = (mean - chosen[:, None]).norm(dim=-1) < min_gap  # (N, Z)
        score = score.masked_fill(near, -torch.inf)
        exhausted = torch.isinf(score).all(dim=-1, keepdim=True)
        score = torch.where(exhausted, at_means, score)
    return torch.stack(picked, dim=-1)


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
        (N, 2) modes.
    """
    return torch.cat(
        [
            _mixture_mode_block(
                log_weights[i : i + chunk],
                mean[i : i + chunk],
                cov[i : i + chunk],
                num_starts,
                max_iters=max_iters,
                tol=tol,
            )
            for i in range(0, len(log_weights), chunk)
        ]
    )


def _mixture_mode_block(
    log_weights: torch.Tensor,
    mean: torch.Tensor,
    cov: torch.Tensor,
    num_starts: int,
    *,
    max_iters: int,
    tol: float,
) -> torch.Tensor:
    log_weights, mean, cov = log_weights.double(), mean.double(), cov.double()
    N, Z = log_weights.shape
    precision, log_det = _precision(cov)  # (N, Z, 3), (N, Z)
    log_norm = log_weights - math.log(2.0 * math.pi) - 0.5 * log_det  # (N, Z)
    prec_mean = torch.stack(
        [
            precision[..., 0] * mean[..., 0] + precision[..., 1] * mean[..., 1],
            precision[..., 1] * mean[..., 0] + precision[..., 2] * mean[..., 1],
        ],
        -1,
    )  # (N, Z, 2)

    # Density of each mixture at each of its own component means: (N, Z, Z) in one go.
    diff = mean[:, :, None, :] - mean[:, None, :, :]  # (N, Z_at, Z_comp, 2)
    at_means = torch.logsumexp(log_norm[:, None] - 0.5 * _quad(diff, precision[:, None]), -1)
    S = min(num_starts, Z)
    starts = _separated_starts(at_means, mean, S)  # (N, S)
    owner = torch.arange(N, device=mean.device).repeat_interleave(S)  # mixture of each start
    points = torch.gather(mean, 1, starts[..., None].expand(-1, -1, 2)).reshape(N * S, 2)
    points, score = _climb(
        points,
        log_norm[owner],
        mean[owner],
        precision[owner],
        prec_mean=prec_mean[owner],
        max_iters=max_iters,
        tol=tol,
    )
    best = score.reshape(N, S).argmax(dim=-1)
    return points.reshape(N, S, 2)[torch.arange(N, device=mean.device), best]


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
