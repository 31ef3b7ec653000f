"""``grouptron config show``: the effective settings of a run, without editing JSON."""

from __future__ import annotations

import argparse
import json

import torch

from grouptron.cli.train import experiment_from_args
from grouptron.config import config_to_dict, non_default_settings


def cmd_config_show(args: argparse.Namespace) -> int:
    """``grouptron config show``: print the run's effective settings as JSON (with
    ``--changes``, only those other than the defaults, one per line)."""
    run_flags = ("epochs", "seed", "batch_size", "lr", "threads", "init_from", "precision")
    full = argparse.Namespace(**vars(args), **dict.fromkeys(run_flags), on_gap="split")
    if full.split is None and full.dataset is None:
        full.split = "eth"
    full.device = torch.device("cpu")
    # No bf16 timing here: training chooses its precision when it starts (--precision auto).
    experiment = experiment_from_args(full, choose_precision=False)
    if args.changes:
        for key, value in non_default_settings(experiment).items():
            print(f"{key} = {json.dumps(value)}")
        return 0
    print(json.dumps(config_to_dict(experiment), indent=2))
    return 0
