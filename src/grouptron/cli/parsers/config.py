"""The parser of ``grouptron config show`` (its handlers: ``grouptron.cli.config``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import Formatter, Parser
from grouptron.constants import SPLITS
from grouptron.geometry import DERIVATIVE_SCHEMES
from grouptron.presets import MODEL_NAMES


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    config = commands.add_parser(
        "config",
        help="show the effective settings of a training run",
        description="Settings of a run as `grouptron train` would build them: the model's preset "
        "on the split, then --config, then each --set.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron config show --model grouptron --split eth\n"
        "  grouptron config show --set train.seed=3 --set group_encoder.group_dim=32 --changes",
    )
    actions = config.add_subparsers(dest="config_command", metavar="ACTION", parser_class=Parser)
    show = actions.add_parser(
        "show",
        help="print the effective configuration as JSON",
        description="Print the configuration `grouptron train` would use (JSON), or with "
        "--changes only the settings that differ from the defaults.",
        formatter_class=Formatter,
    )
    show.add_argument("--split", choices=SPLITS, help="the ETH/UCY split (default: eth)")
    show.add_argument("--dataset", metavar="FILE", help="a dataset of your own instead")
    show.add_argument(
        "--model",
        metavar="MODEL",
        help=f"the model: {', '.join(MODEL_NAMES)} or package.module:Class (default: "
        "--config's, else trajectron++)",
    )
    show.add_argument("--config", help="JSON file of settings laid over the preset")
    show.add_argument(
        "--set", action="append", metavar="SECTION.KEY=VALUE", help="one setting (repeatable)"
    )
    show.add_argument(
        "--derivatives", choices=DERIVATIVE_SCHEMES, help="central or backward derivatives"
    )
    show.add_argument(
        "--changes", action="store_true", help="only the settings that differ from the defaults"
    )
    show.set_defaults(handler="grouptron.cli.config:cmd_config_show")
