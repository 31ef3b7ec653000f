"""Speed of group detection and of Grouptron's extra encoders.

Usage:
    python benchmarks/groups.py [--data-dir DIR] [--iterations 15]

  clustering  cold group assignment of every univ sample (train + val + test): Hausdorff
              distances and clustering vectorised per node count
  iteration   one training iteration (batch 256, all latent values, augmentation) of
              Trajectron++ and of Grouptron on univ, alternated, medians and their ratio
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import numpy as np
import torch

from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.prepare.augment import draw_rotation_angles
from grouptron.groups.assign import assign_groups
from grouptron.model.batch import make_batch
from grouptron.model.elbo import elbo_loss
from grouptron.model.factory import build_model
from grouptron.presets import experiment_preset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir")
    parser.add_argument("--iterations", type=int, default=15)
    args = parser.parse_args()
    torch.set_num_threads(2)
    root = resolve_data_dir(args.data_dir)
    config = experiment_preset("univ", "grouptron")
    parts = {p: load_part(root, "univ", p, config.data).samples for p in ("train", "val", "test")}

    start = time.perf_counter()
    groups = {p: assign_groups(s, config.groups, config.data.position_scale_m)
              for p, s in parts.items()}  # fmt: skip
    clustering_s = time.perf_counter() - start
    total = sum(len(s) for s in parts.values())

    samples, train_groups = parts["train"], groups["train"]
    rng = np.random.default_rng(0)
    models = {name: build_model(dataclasses.replace(config, model_name=name))
              for name in ("trajectron++", "grouptron")}  # fmt: skip
    optimizers = {n: torch.optim.Adam(m.parameters(), lr=1e-3) for n, m in models.items()}

    def step(name: str) -> float:
        index = rng.choice(len(samples), 256, replace=False)
        started = time.perf_counter()
        batch = make_batch(samples, index, config.data, draw_rotation_angles(rng, 256),
                           groups=train_groups if name == "grouptron" else None)  # fmt: skip
        terms = elbo_loss(models[name](batch, logit_clip=1.0), batch, config.loss, 1.0, dt_s=0.4)
        optimizers[name].zero_grad()
        terms.loss.backward()
        optimizers[name].step()
        return time.perf_counter() - started

    times: dict[str, list[float]] = {name: [] for name in models}
    for _ in range(2):
        for name in models:
            step(name)
    for _ in range(args.iterations):
        for name in models:
            times[name].append(step(name))
    medians = {n: statistics.median(t) for n, t in times.items()}
    print("| measure | value |\n|---|---|")
    print(f"| group assignment, univ train+val+test ({total} samples), cold | "
          f"{clustering_s:.1f} s |")  # fmt: skip
    for name, seconds in medians.items():
        print(f"| {name} training iteration (batch 256, univ, incl. batching) | "
              f"{seconds * 1e3:.0f} ms |")  # fmt: skip
    ratio = medians["grouptron"] / medians["trajectron++"]
    print(f"| Grouptron / Trajectron++ iteration time | {ratio:.2f} |")


if __name__ == "__main__":
    main()
