"""The README's Python examples run as written (with a tiny checkpoint under a shipped name,
on a tiny synthetic benchmark)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from tests.conftest import REPO


def _python_blocks() -> list[str]:
    """The README's Python examples: the robot's loop, then training and evaluation."""
    blocks = re.findall(r"```python\n(.*?)```", (REPO / "README.md").read_text(), re.S)
    assert len(blocks) == 2
    return blocks


def test_readme_python_example_runs(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    code, _ = _python_blocks()
    shutil.copy(next((synthetic_data_dir / "eth/test").glob("*.txt")), tmp_path / "my_tracks.txt")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GROUPTRON_CHECKPOINTS", str(tiny_checkpoints))
    namespace: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), namespace)
    forecast = namespace["forecast"]
    assert len(forecast) > 0  # type: ignore[arg-type]


@pytest.mark.slow
def test_readme_training_and_evaluation_example_runs(
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _, code = _python_blocks()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GROUPTRON_DATA", str(synthetic_data_dir))
    namespace: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), namespace)
    printed = capsys.readouterr().out
    assert "done: 2 epochs" in printed and (tmp_path / "runs/eth-try/best.safetensors").is_file()
    assert "grouptron ml FDE" in printed and "grouptron best-of-20 FDE" in printed
    assert "constant-velocity None FDE" in printed
