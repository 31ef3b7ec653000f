"""The ``grouptron`` command line: one module per command, each building its parser next to
its handler (``app`` ties them together)."""

from grouptron.cli.app import build_parser, main

__all__ = ["build_parser", "main"]
