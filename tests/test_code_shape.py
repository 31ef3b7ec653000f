"""The code keeps the shape the architecture asks for: small modules and short functions."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "grouptron"
TESTS = Path(__file__).resolve().parent
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 60
MAX_HANDLER_LINES = 30


def test_no_module_is_longer_than_450_lines() -> None:
    long = {
        str(p.relative_to(SRC)): n
        for p in SRC.rglob("*.py")
        if (n := p.read_text().count("\n")) > MAX_MODULE_LINES
    }
    assert not long


def test_long_functions_say_why() -> None:
    """A function over 60 lines needs a comment right above it that says why."""
    unexplained = []
    for path in SRC.rglob("*.py"):
        lines = path.read_text().splitlines()
        for node in ast.walk(ast.parse("\n".join(lines))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
                above = lines[start - 2].strip() if start >= 2 else ""
                if length > MAX_FUNCTION_LINES and not above.startswith("#"):
                    unexplained.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name}")
    assert not unexplained


def test_command_handlers_are_thin() -> None:
    """A command's handler (``cli/*.py``) reads its options, calls the library's workflow and
    prints the result: no function there is over 30 lines. The parsers (``cli/parsers/``) and
    their shared options (``cli/options.py``) define arguments and are exempt."""
    long = []
    for path in sorted((SRC / "cli").glob("*.py")):  # not cli/parsers/: a folder below
        if path.name == "options.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > MAX_HANDLER_LINES:
                    long.append(f"cli/{path.name}:{node.lineno} {node.name} ({length} lines)")
    assert not long


def _imported_modules(tree: ast.Module, package: list[str]) -> list[str]:
    """Every dotted name an ``import`` or ``from ... import`` of the module names: the module
    itself and, for ``from``, each name under it (it may be a module too)."""
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            names += [module, *(f"{module}.{alias.name}" for alias in node.names)]
    return names


def test_test_modules_never_import_each_other() -> None:
    """What several test modules share lives in tests/helpers/ (or tests/conftest.py,
    tests/golden/), never in a ``test_*`` module that others import."""
    crossing = []
    for path in TESTS.rglob("*.py"):
        package = ["tests", *path.relative_to(TESTS).parent.parts]
        for name in _imported_modules(ast.parse(path.read_text()), package):
            parts = name.split(".")
            if parts[0] == "tests" and any(part.startswith("test_") for part in parts[1:]):
                crossing.append(f"{path.relative_to(TESTS)}: {name}")
    assert not crossing
