"""Online learning on recordings from elsewhere: each replayed in time order learning its site
as a live session would, its later half scored (``grouptron evaluate --tracks F --learn``).

Usage:
    python benchmarks/online_learning.py [--checkpoint NAME] [--datasets A.toml,B.toml]
        [--steps 60] [--round-s 30] [--learning-rate 3e-4] [--scored-from 0.5] [--seed 0]
    python benchmarks/online_learning.py --time FILE [--columns ...] [--minutes 3]

Every test file of the out-of-domain descriptions (default: the development set) is its own
site: a session starts from the checkpoint at the file's start and learns in rounds
(``inference.learning``; rounds in line at recording time, so the replay is deterministic);
forecasts from ``--scored-from`` of the file's duration on are scored with the weights in use
when each was made, beside the checkpoint as shipped and constant velocity on the same
samples. Prints a table per file and pooled (FDE in metres; the paired difference learnt
minus fixed with its 95% interval over time steps) and each file's replay time.

``--time FILE`` instead times ``grouptron predict --tracks --learn`` (the workflow, model
loading included) on the first ``--minutes`` of one recording (written to a temporary
``frame id x y`` file on the 0.4 s step; ``--columns``, ``--fps``, ``--units`` read it), beside
the same command without ``--learn``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.windows import step_window
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
from grouptron.inference.learning import LearningOptions
from grouptron.training.fine_tune import FineTune
from grouptron.workflows.evaluate_learning import (
    LearningEvaluation,
    evaluate_learning,
    learning_table,
)
from grouptron.workflows.predict import PredictRequest, predict_tracks

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET, files_of_test_parts


def time_replay(source: TrackSource, minutes: float) -> None:
    """Seconds of ``predict --learn`` and of ``predict`` on the recording's first minutes."""
    table, _ = read_track_file(source, 10)
    steps = round(minutes * 60 / 0.4)
    cut = step_window(table, 0, steps)
    assert cut is not None
    rows = np.column_stack([cut.step * 10, cut.ped_id, cut.pos_m])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "first.txt"
        np.savetxt(path, rows, fmt=["%d", "%d", "%.4f", "%.4f"])
        people = len(np.unique(cut.ped_id))
        span_min = int(cut.step.max() + 1) * 0.4 / 60
        print(f"{source.path}: the first {span_min:.2f} min, {people} people")
        for learn in (False, True):
            started = time.perf_counter()
            request = PredictRequest(TrackSource(path), Path(folder) / "f.csv", learn=learn)
            done = predict_tracks(request)
            status = "" if done.learning is None else f"; {done.learning.line()}"
            label = "predict --learn" if learn else "predict"
            print(f"  {label}: {time.perf_counter() - started:.1f} s{status}")


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
    parser.add_argument("--time", metavar="FILE", help="time predict --learn on this file")
    parser.add_argument("--minutes", type=float, default=3.0, help="of --time's file")
    parser.add_argument("--columns", help="of --time's file (default frame,id,x,y)")
    parser.add_argument("--fps", type=float, help="of --time's file")
    parser.add_argument("--units", default="m", help="of --time's file")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    if args.time:
        source = TrackSource(args.time, columns=args.columns, fps=args.fps, units=args.units)
        time_replay(source, args.minutes)
        return
    budget = FineTune(steps=args.steps, learning_rate=args.learning_rate)
    options = LearningOptions(round_s=args.round_s, budget=budget, seed=args.seed)
    print(f"checkpoint {args.checkpoint}; {options}\n")
    sources = tuple(files_of_test_parts(args.datasets))
    request = LearningEvaluation(sources, args.checkpoint, options, args.scored_from)
    rows = evaluate_learning(request)
    for row in rows:
        if row.status is not None:
            print(f"{row.name}: replayed in {row.replay_s:.0f} s; {row.status.line()}")
    print()
    print(learning_table(rows))


if __name__ == "__main__":
    main()
