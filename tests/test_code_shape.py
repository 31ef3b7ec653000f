"""The code keeps the shape the architecture asks for: small modules and short functions."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "grouptron"
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 60


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
