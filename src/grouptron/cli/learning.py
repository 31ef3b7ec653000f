"""``--learn`` and its knobs as ``LearningOptions`` (predict, evaluate, ros2)."""

from __future__ import annotations

import argparse

from grouptron.inference.learning import LearningOptions
from grouptron.training.fine_tune import FineTune


def learning_options(args: argparse.Namespace) -> LearningOptions | None:
    """``--learn``'s options (None without it)."""
    if not args.learn:
        return None
    return LearningOptions(round_s=args.learn_round_s, budget=FineTune(steps=args.learn_steps))
