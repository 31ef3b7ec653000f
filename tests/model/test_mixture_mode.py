"""The vectorised mixture-mode finder agrees with the reference's grid search."""

from __future__ import annotations

import pytest
import torch

from grouptron.model import gaussians
from grouptron.model import mixture_mode as mixture_mode_module
from grouptron.model.mixture_mode import grid_mode, mixture_mode


def random_mixtures(n: int, seed: int, spread: float = 0.5) -> tuple[torch.Tensor, ...]:
    g = torch.Generator().manual_seed(seed)
    log_weights = torch.randn(n, 25, generator=g, dtype=torch.float64) * 1.5
    mean = torch.randn(n, 25, 2, generator=g, dtype=torch.float64) * spread
    log_sigma = torch.randn(n, 25, 2, generator=g, dtype=torch.float64) * 0.4 - 1.0
    corr = torch.tanh(torch.randn(n, 25, generator=g, dtype=torch.float64))
    return log_weights, mean, gaussians.covariance_entries(log_sigma, corr)


def fine_grid_mode(
    log_weights: torch.Tensor, mean: torch.Tensor, cov: torch.Tensor
) -> torch.Tensor:
    """The reference's 1 cm grid, then a 0.2 mm grid over +-1.5 cm around its answer."""
    coarse = grid_mode(log_weights, mean, cov, resolution=0.01)
    offsets = torch.arange(-0.015, 0.0151, 0.0002, dtype=torch.float64)
    grid = torch.stack(torch.meshgrid(offsets, offsets, indexing="ij"), -1).reshape(-1, 2)
    grid = grid + coarse
    return grid[log_density_at(grid, log_weights, mean, cov).argmax()]


def log_density_at(
    points: torch.Tensor, log_weights: torch.Tensor, mean: torch.Tensor, cov: torch.Tensor
) -> torch.Tensor:
    n = len(points)
    return gaussians.mixture_log_prob(
        points,
        torch.log_softmax(log_weights, -1).expand(n, -1),
        mean.expand(n, -1, -1),
        cov.expand(n, -1, -1),
    )


def test_single_gaussian_mode_is_its_mean() -> None:
    log_weights, mean, cov = random_mixtures(10, 0)
    mode = mixture_mode(log_weights[:, :1], mean[:, :1], cov[:, :1])
    torch.testing.assert_close(mode, mean[:, 0])


def test_agrees_with_a_fine_grid_to_a_millimetre() -> None:
    log_weights, mean, cov = random_mixtures(40, 1)
    modes = mixture_mode(log_weights, mean, cov, num_starts=25)
    for i in range(len(modes)):
        reference = fine_grid_mode(log_weights[i], mean[i], cov[i])
        ours = log_density_at(modes[i : i + 1], log_weights[i], mean[i], cov[i])
        theirs = log_density_at(reference[None], log_weights[i], mean[i], cov[i])
        assert ours >= theirs - 1e-9, i  # never a worse point than the grid's
        assert (modes[i] - reference).norm() < 1e-3, i


def test_default_search_is_never_worse_than_the_reference_grid() -> None:
    log_weights, mean, cov = random_mixtures(60, 2)
    modes = mixture_mode(log_weights, mean, cov)
    for i in range(len(modes)):
        grid_answer = grid_mode(log_weights[i], mean[i], cov[i], resolution=0.01)
        ours = log_density_at(modes[i : i + 1], log_weights[i], mean[i], cov[i])
        theirs = log_density_at(grid_answer[None], log_weights[i], mean[i], cov[i])
        assert ours >= theirs - 1e-3, i


def test_blocks_side_by_side_give_one_block_s_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    """Large inputs are cut into equal blocks climbed on worker threads; the answer does not
    depend on the cut."""
    log_weights, mean, cov = random_mixtures(50, 3)
    whole = mixture_mode(log_weights, mean, cov)
    monkeypatch.setattr(mixture_mode_module, "PARALLEL_MIN_BLOCK_VALUES", 0)
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        for chunk in (7, 25, 49):
            torch.testing.assert_close(mixture_mode(log_weights, mean, cov, chunk=chunk), whole)
    finally:
        torch.set_num_threads(threads)
    assert mixture_mode(log_weights[:0], mean[:0], cov[:0]).shape == (0, 2)


def test_small_mixtures_climb_on_the_calling_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """A live update's few thousand two-component mixtures start no worker threads (they cost
    more than they save there); the benchmark's 25 components and 4 starts do."""

    class NoThreads:
        def __init__(self, workers: int) -> None:
            raise AssertionError(f"{workers} worker threads started")

    monkeypatch.setattr(mixture_mode_module, "ThreadPoolExecutor", NoThreads)
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        log_weights, mean, cov = random_mixtures(3600, 4)
        mixture_mode(log_weights[:, :2], mean[:, :2], cov[:, :2], num_starts=1)
        with pytest.raises(AssertionError, match="2 worker threads"):
            mixture_mode(log_weights, mean, cov, num_starts=4)
    finally:
        torch.set_num_threads(threads)


def test_a_climb_cut_short_keeps_the_steps_it_made() -> None:
    """With too few iterations for the points to settle, the modes are where the climb got to:
    never below the start (the densest component mean), above it for most mixtures, and
    no higher than with the full iteration budget."""
    log_weights, mean, cov = random_mixtures(40, 5)
    for i in range(len(mean)):
        at_means = log_density_at(mean[i], log_weights[i], mean[i], cov[i])
        start = at_means.max()
        one, full = (
            mixture_mode(log_weights[i : i + 1], mean[i : i + 1], cov[i : i + 1], 1, max_iters=n)
            for n in (1, 30)
        )
        after_one = log_density_at(one, log_weights[i], mean[i], cov[i])[0]
        settled = log_density_at(full, log_weights[i], mean[i], cov[i])[0]
        assert start - 1e-12 <= after_one <= settled + 1e-12, i
    cut = mixture_mode(log_weights, mean, cov, 1, max_iters=1)
    moved = (cut - mixture_mode(log_weights, mean, cov, 1, max_iters=0)).norm(dim=-1) > 1e-6
    assert moved.float().mean() > 0.5
