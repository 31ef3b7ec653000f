"""Train the deployment candidates: the univ-trained `trajectron++-residual` and
`grouptron-robust-residual` seeds 0-2, each fine-tuned on every ETH/UCY recording and the crowds
corpus (`campaign/deployment/eth-ucy-and-crowds.toml`, sources drawn in equal shares).

Usage:
    GROUPTRON_DATA=... GROUPTRON_CROWDS=... python campaign/deployment.py [--out campaign/runs]
        [--only NAME,...] [--status]

One run after the other, one thread each (about 10 min per run on one core of the machine in
benchmarks/RESULTS.md); a finished run (one with `selection.json`) is skipped, a started one
resumed. The runs are then scored on the out-of-domain development set (`python
benchmarks/out_of_domain.py --modes ml-top10 --default-model '' --checkpoints ...`) and the
chosen architecture's three seeds shipped (`campaign/ship.py`).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATASET = REPO / "campaign" / "deployment" / "eth-ucy-and-crowds.toml"
RECIPE = ["--lr", "3e-4", "--epochs", "12", "--set", "train.epoch_samples=40000"]
"""A fine-tune: a fresh optimiser at 3e-4, 12 epochs of 40,000 draws (1,884 steps)."""
STARTS = {"trajectron++-residual": "tpr", "grouptron-robust-residual": "grr"}


def queue() -> dict[str, tuple[str, int]]:
    """Run name -> (the univ checkpoint it starts from, seed)."""
    runs = {}
    for seed in range(3):
        for model, short in STARTS.items():
            suffix = f"-seed{seed}" if seed else ""
            runs[f"deploy-{short}-s{seed}"] = (f"{model}-univ-backward{suffix}", seed)
    return runs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "campaign" / "runs")
    parser.add_argument("--only", help="comma-separated run names")
    parser.add_argument("--status", action="store_true", help="say which runs are finished")
    args = parser.parse_args()
    runs = queue()
    names = args.only.split(",") if args.only else list(runs)
    for name in names:
        folder = args.out / name
        done = (folder / "selection.json").exists()
        if args.status:
            print(f"{name}: {'finished' if done else 'started' if folder.exists() else 'queued'}")
            continue
        if done:
            continue
        start, seed = runs[name]
        command = ["grouptron", "train", "--dataset", str(DATASET), "--init-from", start]
        command += [*RECIPE, "--threads", "1", "--seed", str(seed), "--out", str(folder)]
        command += ["--quiet", *(["--resume"] if (folder / "last.safetensors").exists() else [])]
        print(" ".join(command), flush=True)
        if subprocess.run(command, check=False).returncode:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
