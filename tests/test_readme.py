"""The README's Python example runs as written (with a tiny checkpoint under a shipped name)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from tests.conftest import REPO


def test_readme_python_example_runs(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    (code,) = re.findall(r"```python\n(.*?)```", (REPO / "README.md").read_text(), re.S)
    shutil.copy(next((synthetic_data_dir / "eth/test").glob("*.txt")), tmp_path / "my_tracks.txt")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GROUPTRON_CHECKPOINTS", str(tiny_checkpoints))
    namespace: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), namespace)
    forecast = namespace["forecast"]
    assert len(forecast) > 0  # type: ignore[arg-type]
