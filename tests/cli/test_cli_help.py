"""Every command's --help: each option explained, each default noted once, never "None"."""

from __future__ import annotations

import argparse
import re

import pytest

from grouptron.cli import build_parser


def _parsers() -> dict[str, argparse.ArgumentParser]:
    found = {"grouptron": build_parser()}
    pending = list(found.items())
    while pending:
        name, parser = pending.pop()
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub, child in action.choices.items():
                    found[f"{name} {sub}"] = child
                    pending.append((f"{name} {sub}", child))
    return found


PARSERS = _parsers()


def test_every_command_is_reached() -> None:
    names = set(PARSERS)
    assert {"grouptron train", "grouptron data stats", "grouptron groups evaluate"} <= names


@pytest.mark.parametrize("name", sorted(PARSERS))
def test_help_explains_every_option_and_states_defaults_once(name: str) -> None:
    parser = PARSERS[name]
    for action in parser._actions:
        if action.option_strings and action.help is not argparse.SUPPRESS:
            assert action.help, f"{name} {action.option_strings[0]} has no help"
    text = parser.format_help()
    assert "(default: None)" not in text
    flat = re.sub(r"\s+", " ", text)
    for entry in re.split(r" (?=-{1,2}[a-z])", flat):
        assert entry.lower().count("default") <= 1, f"{name}: {entry}"


COMPUTING = ("evaluate", "predict", "plot", "report", "train", "export")
"""Commands that run a network: each takes --threads."""


@pytest.mark.parametrize("name", COMPUTING)
def test_every_command_that_computes_takes_threads(name: str) -> None:
    options = {o for a in PARSERS[f"grouptron {name}"]._actions for o in a.option_strings}
    assert "--threads" in options


@pytest.mark.parametrize(
    "command", [[], ["predict"], ["plot"], ["evaluate"], ["train"], ["report"], ["export"]]
)
def test_help_never_imports_torch(command: list[str]) -> None:
    """``--help`` is instant: only the parsers load; each handler imports what it needs."""
    import subprocess
    import sys

    code = (
        "import sys\nfrom grouptron.cli.app import main\n"
        f"try:\n    main({[*command, '--help']!r})\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in ('torch', 'scipy', 'matplotlib') if m in sys.modules))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip().splitlines()[-1] == "[]", run.stdout[-300:]
