"""Time of the mixture mode on one thread and on worker threads, by mixture count.

Usage:
    python benchmarks/mixture_mode.py [--counts 3600,8000,16000,32000] [--repeats 5]

Random mixtures shaped as forecasts climb them: a live update's ``ml-top2`` (2 components,
1 start; 12 mixtures per person, so 3600 at 300 people), ``ml-top10`` and ``ml-top25`` (1
start) and the benchmark's most likely forecast (25 components, 4 starts); counts above the
2048 mixtures of one block, so that there are blocks to share. For each count, the median ms of
:func:`~grouptron.model.mixture_mode.mixture_mode` climbing on the calling thread and split
into blocks on ``--threads`` worker threads: the workers pay only when a block's arrays are
large (:data:`~grouptron.model.mixture_mode.PARALLEL_MIN_BLOCK_VALUES`, mixtures x components
x starts), as with the benchmark's 25 components and 4 starts, and cost time with the live
forecasts' 2 or 10 components and 1 start.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch

from grouptron.model import gaussians, mixture_mode

SHAPES = (("ml-top2", 2, 1), ("ml-top10", 10, 1), ("ml-top25", 25, 1), ("ml (benchmark)", 25, 4))
"""(name, components, starts) of the mixtures timed."""


def random_mixtures(
    count: int, components: int, seed: int = 0
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(N, Z) log weights, (N, Z, 2) means, (N, Z, 3) covariance entries."""
    g = torch.Generator().manual_seed(seed)
    log_weights = torch.randn(count, components, generator=g, dtype=torch.float64)
    mean = torch.randn(count, components, 2, generator=g, dtype=torch.float64) * 0.5
    log_sigma = torch.randn(count, components, 2, generator=g, dtype=torch.float64) * 0.4 - 1
    corr = torch.tanh(torch.randn(count, components, generator=g, dtype=torch.float64))
    return log_weights, mean, gaussians.covariance_entries(log_sigma, corr)


def median_ms(
    mixtures: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    starts: int,
    parallel: bool,
    repeats: int,
) -> float:
    """Median ms of ``repeats`` climbs, on worker threads or not."""
    threshold = mixture_mode.PARALLEL_MIN_BLOCK_VALUES
    mixture_mode.PARALLEL_MIN_BLOCK_VALUES = 0 if parallel else 2**62
    try:
        times = []
        for _ in range(repeats + 1):  # the first warms up
            start = time.perf_counter()
            mixture_mode.mixture_mode(*mixtures, starts)
            times.append(time.perf_counter() - start)
    finally:
        mixture_mode.PARALLEL_MIN_BLOCK_VALUES = threshold
    return 1e3 * statistics.median(times[1:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--counts", default="3600,8000,16000,32000")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(
        f"median ms; {args.threads} worker threads, used from "
        f"{mixture_mode.PARALLEL_MIN_BLOCK_VALUES} values a block"
    )
    print(f"{'mixtures':>16} {'count':>7} {'one thread':>11} {'workers':>8}")
    for name, components, starts in SHAPES:
        for count in (int(c) for c in args.counts.split(",")):
            mixtures = random_mixtures(count, components)
            one = median_ms(mixtures, starts, False, args.repeats)
            workers = median_ms(mixtures, starts, True, args.repeats)
            print(f"{name:>16} {count:>7} {one:>11.1f} {workers:>8.1f}")


if __name__ == "__main__":
    main()
