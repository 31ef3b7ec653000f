"""The ``grouptron`` command: the top-level parser, global options and the one error policy.

Errors caused by input are printed on one line and end the program with exit code 2."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from collections.abc import Callable, Sequence

from grouptron import __version__
from grouptron.cli.options import EXIT_USAGE, Formatter, Parser
from grouptron.cli.parsers import (
    adapt,
    compare,
    config,
    data,
    evaluate,
    export,
    forecast,
    groups,
    report,
    ros2,
    train,
)
from grouptron.errors import GrouptronError


def build_parser() -> argparse.ArgumentParser:
    """The ``grouptron`` parser: global options and every command's subparser."""
    parser = Parser(
        prog="grouptron",
        description="Group-aware pedestrian trajectory forecasting on ETH/UCY "
        "(Grouptron and Trajectron++).",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron data fetch\n"
        "  grouptron data stats --split all\n"
        "  grouptron evaluate --model constant-velocity --split all\n"
        "  grouptron train --split eth --epochs 10\n"
        "  grouptron evaluate --checkpoint grouptron-eth-central\n\n"
        "Run 'grouptron COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"grouptron {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more detail")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    commands_in_order = (data, evaluate, compare, report, forecast, export, train, adapt)
    for module in (*commands_in_order, groups, config, ros2):
        module.add_parser(commands)
    _accept_global_options_everywhere(parser)
    return parser


def _accept_global_options_everywhere(parser: argparse.ArgumentParser) -> None:
    """``-v`` also after a command (``grouptron train ... -v``); SUPPRESS keeps a command's
    parser from resetting what was given before the command."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                child.add_argument(
                    "-v",
                    "--verbose",
                    action="store_true",
                    default=argparse.SUPPRESS,
                    help="log more detail",
                )
                _accept_global_options_everywhere(child)


def _handler(named: str) -> Callable[[argparse.Namespace], int]:
    """The function ``"module:function"`` names, imported now: a command's handler and what it
    needs (PyTorch, SciPy, matplotlib) load only when that command runs, never for --help."""
    module, _, function = named.partition(":")
    handler: Callable[[argparse.Namespace], int] = getattr(
        importlib.import_module(module), function
    )
    return handler


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``grouptron`` console script; returns the exit code."""
    logging.basicConfig(format="grouptron: %(levelname)s: %(message)s", level=logging.WARNING)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.verbose:
            logging.getLogger().setLevel(logging.INFO)
        named: str | None = getattr(args, "handler", None)
        if named is None:
            # A command group without an action: show its help.
            target = args.command if args.command in ("data", "groups", "config") else None
            if target:
                parser.parse_args([target, "--help"])
            parser.print_help()
            return EXIT_USAGE
        return _handler(named)(args)
    except GrouptronError as exc:
        print(f"grouptron: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:  # `grouptron ... | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # unwritable output, full disk, a folder given as a file, ...
        print(f"grouptron: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("grouptron: interrupted", file=sys.stderr)
        return 130
