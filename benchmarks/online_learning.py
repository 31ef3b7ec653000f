"""Online learning on recordings from elsewhere: each replayed in time order learning its site
as a live session would, its later half scored (``grouptron evaluate --tracks F --learn``).

Usage:
    python benchmarks/online_learning.py [--checkpoint NAME] [--datasets A.toml,B.toml]
        [--steps 60] [--round-s 30] [--learning-rate 3e-4] [--scored-from 0.5] [--seed 0]

Every test file of the out-of-domain descriptions (default: the development set) is its own
site: a session starts from the checkpoint at the file's start and learns in rounds
(``inference.learning``; rounds in line at recording time, so the replay is deterministic);
forecasts from ``--scored-from`` of the file's duration on are scored with the weights in use
when each was made, beside the checkpoint as shipped and constant velocity on the same
samples. Prints a table per file and pooled (FDE in metres; the paired difference learnt
minus fixed with its 95% interval over time steps) and each file's replay time.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
from grouptron.inference.learning import LearningOptions
from grouptron.training.fine_tune import FineTune
from grouptron.workflows.evaluate_learning import (
    LearningEvaluation,
    evaluate_learning,
    learning_table,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET


def recordings(descriptions: str) -> list[TrackSource]:
    """Every test file of the descriptions, with its layout."""
    sources = []
    for description in descriptions.split(","):
        dataset = read_dataset(description)
        sources += [TrackSource.from_format(f, dataset.recording) for f in dataset.files("test")]
    return sources


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--datasets", default=DEVELOPMENT_SET)
    defaults = LearningOptions()
    parser.add_argument("--steps", type=int, default=defaults.budget.steps)
    parser.add_argument("--round-s", type=float, default=defaults.round_s)
    parser.add_argument("--learning-rate", type=float, default=defaults.budget.learning_rate)
    parser.add_argument("--scored-from", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=2, help="forecasting threads")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    budget = FineTune(steps=args.steps, learning_rate=args.learning_rate)
    options = LearningOptions(round_s=args.round_s, budget=budget, seed=args.seed)
    print(f"checkpoint {args.checkpoint}; {options}\n")
    sources = tuple(recordings(args.datasets))
    request = LearningEvaluation(sources, args.checkpoint, options, args.scored_from)
    rows = evaluate_learning(request)
    for row in rows:
        if row.status is not None:
            print(f"{row.name}: replayed in {row.replay_s:.0f} s; {row.status.line()}")
    print()
    print(learning_table(rows))


if __name__ == "__main__":
    main()
