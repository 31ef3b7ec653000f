"""The documentation agrees with the code: every ``--option`` the docs name for a ``grouptron``
command is an option of that command's parser (one named without its command, of some
command's), and the layer lists of README.md, CONTRIBUTING.md and docs/architecture.md are
the import contract of pyproject.toml."""

from __future__ import annotations

import argparse
import re
import sys

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # the tomli backport, a dependency below 3.11
    import tomli as tomllib

from grouptron.cli.app import build_parser
from tests.conftest import REPO

DOCS = [REPO / "README.md", REPO / "CONTRIBUTING.md", *sorted((REPO / "docs").glob("*.md"))]
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
CHAIN_SEPARATORS = re.compile(r"\s(?:\||&&|;|>|2>)\s")
Command = tuple[str, ...]


def command_options() -> dict[Command, set[str]]:
    """Every command path (``("evaluate",)``, ``("groups", "detect")``; ``()`` for the
    top-level parser) with its option strings."""
    found: dict[Command, set[str]] = {}

    def walk(parser: argparse.ArgumentParser, path: Command) -> None:
        found[path] = set(parser._option_string_actions)
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    walk(child, (*path, name))

    walk(build_parser(), ())
    return found


COMMANDS = command_options()
EVERY_OPTION = set().union(*COMMANDS.values())
SCRIPT_OPTIONS = {
    option
    for script in (*REPO.glob("benchmarks/*.py"), *REPO.glob("campaign/*.py"))
    for option in re.findall(r"[\"'](--[a-z][a-z0-9-]*)[\"']", script.read_text())
}
"""Options of the repository's scripts (benchmarks/, campaign/), which the docs name too."""
OTHER_PROGRAMS = {"--depth": "git clone --depth 1, in README's install section"}
"""Options of other programs the docs name in prose, with where."""


def _pieces(text: str) -> list[str]:
    """The code a document shows: inline code spans, and the lines of its shell and console
    blocks (a ``$`` prompt cut, continuation lines joined); Python blocks are not commands."""
    pieces = []
    blocks = re.findall(r"```(\w*)\n(.*?)```", text, re.S)
    for kind, block in blocks:
        if kind in ("bash", "console", "sh", "shell", ""):
            for line in block.replace("\\\n", " ").splitlines():
                pieces.append(line.removeprefix("$ ").strip())
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    pieces += re.findall(r"`([^`\n]+)`", prose)
    return pieces


def _command(words: list[str]) -> tuple[Command, list[str]] | None:
    """The command a piece of code runs (``grouptron`` itself may be left out) and the words
    after it; None where it runs another program."""
    if words and words[0] == "grouptron":
        words = words[1:]
    path: Command = ()
    while words and (*path, words[0]) in COMMANDS:
        path, words = (*path, words[0]), words[1:]
    return (path, words) if path else None


def documented_options() -> list[tuple[str, Command | None, str, str]]:
    """(document, command or None, option, the code it was read from) of every option the
    documents name: None where the code names options alone (``--units cm``)."""
    found = []
    for doc in DOCS:
        for piece in _pieces(doc.read_text()):
            for part in CHAIN_SEPARATORS.split(piece):
                words = part.split()
                if not words:
                    continue
                command = _command(words)
                if command is None and not words[0].startswith("--"):
                    continue  # another program: git, pip, python, make, a script
                path = command[0] if command else None
                if "--ros-args" in words:  # what follows is ROS's: --params-file, -p
                    words = words[: words.index("--ros-args") + 1]
                for option in OPTION.findall(" ".join(words)):
                    found.append((doc.name, path, option, part))
    return found


DOCUMENTED = documented_options()


def test_the_docs_name_options() -> None:
    named = {(path, option) for _, path, option, _ in DOCUMENTED}
    assert len(named) > 100  # the collector finds them (a regex gone wrong finds none)
    assert (("report",), "--split") in named and (("evaluate",), "--metrics") in named


@pytest.mark.parametrize(
    ("doc", "path", "option", "code"),
    DOCUMENTED,
    ids=[f"{d}:{' '.join(p or ('*',))}:{o}" for d, p, o, _ in DOCUMENTED],
)
def test_every_documented_option_exists(
    doc: str, path: Command | None, option: str, code: str
) -> None:
    """An option named for a command is that command's (or a global one); one named alone
    is some command's, a script's or another program's the docs name."""
    alone = EVERY_OPTION | SCRIPT_OPTIONS | set(OTHER_PROGRAMS)
    known = alone if path is None else COMMANDS[path] | COMMANDS[()]
    assert option in known, f"{doc}: `{code}` names {option}, which {path or 'no command'} lacks"


def contract_layers() -> list[set[str]]:
    """The layers of the import contract, top first, each a set of module names."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    contract = config["tool"]["importlinter"]["contracts"][0]
    return [
        {name.strip().removeprefix("grouptron.") for name in layer.split(":")}
        for layer in contract["layers"]
    ]


def _chain(text: str) -> list[set[str]]:
    """The layers of a written chain ``cli`` > ``workflows`` > ... > ``errors``."""
    flat = " ".join(text.split())
    start = flat.index("`cli` > ")
    chain = flat[start : flat.index("`errors`", start) + len("`errors`")]
    return [set(re.findall(r"`(\w+)`", layer)) for layer in chain.split(" > ")]


@pytest.mark.parametrize("doc", ["README.md", "CONTRIBUTING.md"])
def test_the_written_layer_chain_is_the_contract(doc: str) -> None:
    assert _chain((REPO / doc).read_text()) == contract_layers()


def test_the_architecture_diagram_and_list_are_the_contract() -> None:
    text = (REPO / "docs" / "architecture.md").read_text()
    mermaid = re.search(r"```mermaid\n(.*?)```", text, re.S)
    assert mermaid is not None
    drawn: list[set[str]] = []
    for line in mermaid.group(1).splitlines():
        for node in (n.strip() for n in line.split("-->") if "-->" in line):
            label = re.fullmatch(r'\w+\["(.*)"\]', node)
            layer = set(label.group(1).split(" · ")) if label else {node}
            if not drawn or drawn[-1] != layer:  # a line starts where the last one ended
                drawn.append(layer)
    assert drawn == contract_layers()

    listing = re.search(r"```\n(cli/.*?)```", text, re.S)
    assert listing is not None
    names = []
    for line in listing.group(1).splitlines():
        if line and not line.startswith(" "):
            head = re.split(r"\s{2,}", line)[0]
            names += [n.strip().rstrip("/") for n in head.split(",") if n.strip()]
    layers = contract_layers()
    listed = []
    for layer in layers:  # the list gives the order; a layer's members may come in any order
        listed.append(set(names[: len(layer)]))
        names = names[len(layer) :]
    assert listed == layers and not names
