"""Training and evaluation speed of the Trajectron++ CVAE on this machine.

Usage:
    python benchmarks/training.py [--data-dir DIR] [--checkpoint CKPT] [--iterations 20]

Each part runs in its own process (so its peak resident memory is its own) with 2 threads:
  matmul  the machine's fp32 matrix-multiply rate (2048^2 GEMM, and the decoder's GEMM shape)
  train   samples/s at batch 256 on the eth split, all 25 latent values decoded, rotation
          augmentation on; FLOPs of one iteration (forward + backward) by torch's counter
  eval    ML evaluation of all five test splits and best-of-20 on eth (with CKPT if given,
          otherwise an untrained model)
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

REFERENCE_SAMPLES_PER_S = 457.0  # the public implementation on this machine type
REFERENCE_PEAK_GB = 7.65


def peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def matmul_rate() -> dict[str, float]:
    def rate(m: int, k: int, n: int, repeats: int) -> float:
        a, b = torch.randn(m, k), torch.randn(k, n)
        a @ b
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            a @ b
            times.append(time.perf_counter() - start)
        return 2 * m * k * n / statistics.median(times) / 1e9

    return {
        "gemm_2048_gflops": rate(2048, 2048, 2048, 10),
        "gemm_decoder_gflops": rate(6400, 128, 384, 30),
    }


def train_speed(data_dir: Path | None, iterations: int) -> dict[str, float]:
    from torch.utils.flop_counter import FlopCounterMode

    from grouptron.config import ExperimentConfig
    from grouptron.data.datasets.dataset import load_part
    from grouptron.data.datasets.locate import resolve_data_dir
    from grouptron.data.prepare.augment import draw_rotation_angles
    from grouptron.model.batch import make_batch
    from grouptron.model.elbo import elbo_loss
    from grouptron.model.factory import build_model

    config = ExperimentConfig()
    samples = load_part(resolve_data_dir(data_dir), "eth", "train", config.data).samples
    model = build_model(config).train()
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    rng = np.random.default_rng(0)

    def step(count_flops: bool = False) -> float:
        index = rng.choice(len(samples), 256, replace=False)
        batch = make_batch(samples, index, config.data, draw_rotation_angles(rng, 256))
        counter = FlopCounterMode(display=False) if count_flops else None
        if counter is not None:
            counter.__enter__()
        terms = elbo_loss(model(batch, logit_clip=1.0), batch, config.loss, 1.0, dt_s=0.4)
        optimizer.zero_grad()
        terms.loss.backward()
        if counter is not None:
            counter.__exit__(None, None, None)
            return float(counter.get_total_flops())
        torch.nn.utils.clip_grad_value_(model.parameters(), 1.0)
        optimizer.step()
        return 0.0

    flops = step(count_flops=True)
    for _ in range(3):
        step()
    times = []
    for _ in range(iterations):
        start = time.perf_counter()
        step()
        times.append(time.perf_counter() - start)
    seconds = statistics.median(times)
    return {
        "seconds_per_iteration": seconds,
        "samples_per_s": 256 / seconds,
        "gflop_per_iteration": flops / 1e9,
        "peak_rss_gb": peak_rss_gb(),
    }


def eval_speed(data_dir: Path | None, checkpoint: str | None) -> dict[str, float]:
    from grouptron.config import ExperimentConfig
    from grouptron.constants import SPLITS
    from grouptron.data.datasets.dataset import load_part
    from grouptron.data.datasets.locate import resolve_data_dir
    from grouptron.evaluation.evaluate import evaluate_model
    from grouptron.model.checkpoint import load_trained_model
    from grouptron.model.factory import build_model

    config = ExperimentConfig()
    model = build_model(config)
    if checkpoint:
        model, config = load_trained_model(checkpoint)
    root = resolve_data_dir(data_dir)
    tests = {s: load_part(root, s, "test", config.data).samples for s in SPLITS}
    start = time.perf_counter()
    count = 0
    for samples in tests.values():
        evaluate_model(model, config, samples, ("ml",))
        count += len(samples)
    ml_seconds = time.perf_counter() - start
    start = time.perf_counter()
    evaluate_model(model, config, tests["eth"], ("best-of-20",))
    best_seconds = time.perf_counter() - start
    return {
        "ml_seconds_all_test": ml_seconds,
        "ml_samples": count,
        "best_of_20_seconds_eth": best_seconds,
        "peak_rss_gb": peak_rss_gb(),
    }


def run_part(part: str, args: argparse.Namespace) -> dict[str, float]:
    command = [sys.executable, __file__, "--part", part, "--iterations", str(args.iterations)]
    if args.data_dir:
        command += ["--data-dir", args.data_dir]
    if args.checkpoint:
        command += ["--checkpoint", args.checkpoint]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir")
    parser.add_argument("--checkpoint")
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--part", choices=("matmul", "train", "eval"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    torch.set_num_threads(2)
    if args.part:
        result = {
            "matmul": lambda: matmul_rate(),
            "train": lambda: train_speed(args.data_dir, args.iterations),
            "eval": lambda: eval_speed(args.data_dir, args.checkpoint),
        }[args.part]()
        print(json.dumps(result))
        return
    mm, tr, ev = (run_part(p, args) for p in ("matmul", "train", "eval"))
    achieved = tr["gflop_per_iteration"] / tr["seconds_per_iteration"]
    rows = [
        ("fp32 GEMM 2048^3", f"{mm['gemm_2048_gflops']:.0f} GFLOP/s"),
        ("fp32 GEMM 6400x128x384 (decoder shape)", f"{mm['gemm_decoder_gflops']:.0f} GFLOP/s"),
        (
            "training, batch 256, eth",
            f"{tr['seconds_per_iteration'] * 1e3:.0f} ms/iteration, "
            f"{tr['samples_per_s']:.0f} samples/s "
            f"({tr['samples_per_s'] / REFERENCE_SAMPLES_PER_S:.2f}x the reference's 457)",
        ),
        ("FLOPs of one training iteration", f"{tr['gflop_per_iteration']:.1f} GFLOP"),
        (
            "achieved rate / GEMM rate",
            f"{achieved:.0f} GFLOP/s = "
            f"{achieved / mm['gemm_2048_gflops']:.0%} of the 2048^3 GEMM rate",
        ),
        (
            "training peak resident memory",
            f"{tr['peak_rss_gb']:.2f} GB (reference {REFERENCE_PEAK_GB} GB)",
        ),
        (
            f"ML evaluation, all 5 test splits ({ev['ml_samples']} samples)",
            f"{ev['ml_seconds_all_test']:.1f} s",
        ),
        ("best-of-20, eth test (364 samples)", f"{ev['best_of_20_seconds_eth']:.1f} s"),
        ("evaluation peak resident memory", f"{ev['peak_rss_gb']:.2f} GB"),
    ]
    print("| measure | value |\n|---|---|")
    for name, value in rows:
        print(f"| {name} | {value} |")


if __name__ == "__main__":
    main()
