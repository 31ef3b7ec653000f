"""The parser of ``grouptron train`` (its handlers: ``grouptron.cli.train``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import Formatter, add_data_options, device_type
from grouptron.constants import ALL_LOCATIONS, PRECISIONS, SPLITS
from grouptron.presets import MODEL_NAMES


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    train_cmd = commands.add_parser(
        "train",
        help="train a model on one split",
        description="Train a model on the training part of a split, validating on its "
        "validation part after every epoch. The output folder gets last.safetensors (full "
        "state; --resume continues from it exactly), best.safetensors (weights with the best "
        "validation ML FDE) and metrics.jsonl/metrics.csv.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron train --split eth --model trajectron++ --epochs 10\n"
        "  grouptron train --split univ --derivatives central    # the papers' protocol\n"
        "  grouptron train --out runs/trajectron++-eth-backward --resume --epochs 20\n"
        "  grouptron train --dataset mylab.toml --init-from trajectron++-residual-univ-backward "
        "--epochs 5",
    )
    train_cmd.add_argument(
        "--split",
        choices=(*SPLITS, ALL_LOCATIONS),
        help=f"the ETH/UCY split (its location is held out); {ALL_LOCATIONS}: the train and "
        "val parts of all five locations, nothing held out and no validation (the last epoch "
        "is kept): a model for use, never for benchmark tables",
    )
    train_cmd.add_argument(
        "--dataset",
        metavar="FILE",
        help="train on a dataset of your own instead: a TOML or JSON description of its train, "
        "val and test files and their format (docs/recordings.md); no ETH/UCY presets apply",
    )
    train_cmd.add_argument(
        "--model",
        metavar="MODEL",
        help="trajectron++ or grouptron (the paper's), grouptron-robust (Grouptron with "
        "every density switch on; README, 'Grouptron'), trajectron++-residual (velocities "
        "relative to the current one) or grouptron-robust-residual (both); or a model of "
        "your own: package.module:Class (a module installed or in the current folder) or a "
        "'grouptron.models' entry point, its settings given as --set "
        "model_settings.NAME=VALUE (docs/models.md) (default: a --config file's model_name, "
        f"else trajectron++; shipped: {', '.join(MODEL_NAMES)})",
    )
    train_cmd.add_argument("--epochs", type=int, help="epochs (default 100, as the reference)")
    train_cmd.add_argument("--out", help="output folder (default runs/MODEL-SPLIT-DERIVATIVES)")
    train_cmd.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out with its stored configuration; --out alone is enough "
        "(--epochs may extend it)",
    )
    train_cmd.add_argument(
        "--init-from",
        metavar="CHECKPOINT",
        help="start from a checkpoint (a shipped name or a file): the run takes its model, "
        "architecture, groups, input scales and derivatives (unless given here). A weights-only "
        "file (best.safetensors, a shipped name) fine-tunes with a fresh optimiser at --lr; a "
        "last.safetensors continues its optimiser and step count, at --lr when given",
    )
    _add_settings_options(train_cmd)
    add_data_options(train_cmd, derivatives_default="backward")
    train_cmd.set_defaults(handler="grouptron.cli.train:cmd_train")


def _add_settings_options(train_cmd: argparse.ArgumentParser) -> None:
    """Where the run's settings come from, and the common ones as flags."""
    train_cmd.add_argument(
        "--config",
        help="JSON file of settings laid over the model's preset (any subset of "
        "ExperimentConfig; its model_name is used unless --model is given)",
    )
    train_cmd.add_argument(
        "--set",
        action="append",
        metavar="SECTION.KEY=VALUE",
        help="one setting, e.g. --set group_encoder.group_dim=32 --set train.lr_decay_per_iter=1 "
        "(repeatable; applied after --config, before the other flags)",
    )
    train_cmd.add_argument(
        "--seed", type=int, help="seed of initialisation, order and noise (default 0)"
    )
    train_cmd.add_argument(
        "--batch-size", type=int, help="samples per optimiser step (default 256)"
    )
    train_cmd.add_argument("--lr", type=float, help="initial learning rate")
    train_cmd.add_argument("--threads", type=int, help="CPU threads (default 2)")
    train_cmd.add_argument(
        "--precision",
        choices=PRECISIONS,
        help="arithmetic of the decoder: bf16 autocast or fp32; auto (the default) picks bf16 "
        "where the hardware has it natively (CUDA, or a CPU with AVX-512 BF16 or AMX) and fp32 "
        "elsewhere, where bf16 is emulated and slow. Without this option a --config file's "
        "train.bf16 holds, and --resume keeps the run's precision",
    )
    train_cmd.add_argument("--quiet", action="store_true", help="no progress bars")
    train_cmd.add_argument(
        "--device", type=device_type, default="cpu", help="torch device, e.g. cpu or cuda"
    )
