"""Training speed in fp32 against bf16 autocast on this machine, side by side.

Usage:
    python benchmarks/precision.py [--iterations 12] [--threads 1] [--data-dir DIR]

Runs training iterations (batch 256, eth, all 25 latent values, rotation augmentation) in one
process, alternating fp32 and bf16 step by step so that both see the same machine load, and
prints each one's median time per iteration and the ratio. Also prints what
``--precision auto`` would choose here (from the CPU flags) so the two can be compared: a CPU
that announces native bf16 is not always faster with it.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.prepare.augment import draw_rotation_angles
from grouptron.model.batch import make_batch
from grouptron.model.elbo import elbo_loss
from grouptron.model.factory import build_model
from grouptron.training.model_card import describe_device
from grouptron.training.precision import cpu_flags, native_bf16


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=12)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--data-dir")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = ExperimentConfig()
    samples = load_part(resolve_data_dir(args.data_dir), "eth", "train", config.data).samples
    model = build_model(config).train()
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    rng = np.random.default_rng(0)

    def step(bf16: bool) -> float:
        index = rng.choice(len(samples), 256, replace=False)
        batch = make_batch(samples, index, config.data, draw_rotation_angles(rng, 256))
        start = time.perf_counter()
        output = model(batch, logit_clip=1.0, bf16=bf16)
        terms = elbo_loss(output, batch, config.loss, 1.0, dt_s=0.4)
        optimizer.zero_grad()
        terms.loss.backward()
        optimizer.step()
        return time.perf_counter() - start

    for bf16 in (False, True, False, True):  # warm up both paths
        step(bf16)
    times: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(args.iterations):
        for bf16 in (False, True):
            times[bf16].append(step(bf16))
    fp32, bf16 = statistics.median(times[False]), statistics.median(times[True])
    flags = sorted({"avx512_bf16", "amx_bf16"} & cpu_flags())
    print(f"machine: {describe_device(torch.device('cpu'), args.threads)}; bf16 flags: {flags}")
    print(f"auto would choose: {'bf16' if native_bf16(torch.device('cpu')) else 'fp32'}")
    print("| precision | ms per iteration (median) | samples/s |\n|---|---|---|")
    for name, seconds in (("fp32", fp32), ("bf16 autocast", bf16)):
        print(f"| {name} | {seconds * 1e3:.0f} | {256 / seconds:.0f} |")
    print(f"\nbf16 / fp32 time: {bf16 / fp32:.2f}")


if __name__ == "__main__":
    main()
