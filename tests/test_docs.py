"""The documentation runs: every ``grouptron`` command in README.md and docs/ parses as
written, the README's first three commands run end to end on a seconds CSV with a header, and
every Python block runs (with tiny checkpoints under the shipped names); the commands of docs/
run in tests/test_doc_commands.py."""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import build_parser, main
from grouptron.constants import DEFAULT_CHECKPOINT
from tests.conftest import REPO
from tests.helpers.docs import shell_commands

DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
PYTHON_SKIPPED: dict[str, str] = {
    "README.md:1": "trains for two epochs: test_readme.py runs it once and checks what it prints",
}
"""Python blocks (by file) not run here, each with why."""


DOC_COMMANDS = [(p.name, c) for p in DOCS for c in shell_commands(p)]


def test_the_docs_show_commands() -> None:
    assert len(DOC_COMMANDS) >= 30  # the collector finds them (a regex gone wrong finds none)


@pytest.mark.parametrize(("doc", "command"), DOC_COMMANDS)
def test_every_documented_command_parses(doc: str, command: str) -> None:
    """A documented command whose options do not exist (or no longer do) fails here."""
    parser = build_parser()
    try:
        args = parser.parse_args(shlex.split(command)[1:])
    except SystemExit as stop:  # --help exits 0
        assert stop.code == 0, f"{doc}: {command}"
        return
    assert getattr(args, "handler", None) or args.command in ("data", "groups", "config")


def seconds_csv(path: Path, people: int = 5, seconds: float = 13.0) -> Path:
    """A 10 Hz tracker CSV in seconds and metres with a header, as the README's first example."""
    rng = np.random.default_rng(0)
    rows = ["time_s,person,x_m,y_m"]
    for person in range(1, people + 1):
        start, velocity = rng.uniform(-3, 3, 2), rng.normal(0, 0.6, 2)
        for t in np.arange(0.0, seconds, 0.1):
            x, y = start + velocity * t
            rows.append(f"{t:.1f},{person},{x:.3f},{y:.3f}")
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def shipped_names(tiny_checkpoints: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Tiny checkpoints under the shipped names the docs use, the default model's included."""
    folder = tmp_path / "checkpoints"
    shutil.copytree(tiny_checkpoints, folder)
    shutil.copytree(tiny_checkpoints / "grouptron-eth-backward", folder / DEFAULT_CHECKPOINT)
    monkeypatch.setenv("GROUPTRON_CHECKPOINTS", str(folder))
    return folder


@pytest.mark.slow
def test_the_readme_first_three_commands_run_as_written(
    shipped_names: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("## Forecast your tracks") :]
    (example,) = re.findall(r"```text\n(.*?)```", section, re.S)[:1]
    assert example.splitlines()[0] == "time_s,person,x_m,y_m"
    commands = [c for c in shell_commands(REPO / "README.md") if "my_tracks.csv" in c]
    assert [c.split()[1] for c in commands] == ["predict", "plot", "evaluate"]
    monkeypatch.chdir(tmp_path)
    seconds_csv(tmp_path / "my_tracks.csv")
    for command in commands:
        assert main(shlex.split(command)[1:]) == 0, command
    header = (tmp_path / "forecasts.csv").read_text().splitlines()[0]
    assert header == "frame,id,step,x_m,y_m,t_s"
    assert (tmp_path / "forecasts.png").stat().st_size > 10_000


PYTHON_BLOCKS = [
    (p.name, i, code)
    for p in DOCS
    for i, code in enumerate(re.findall(r"```python\n(.*?)```", p.read_text(), re.S))
]


@pytest.mark.parametrize(("doc", "index", "code"), PYTHON_BLOCKS)
def test_every_python_block_runs(
    doc: str,
    index: int,
    code: str,
    shipped_names: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    if f"{doc}:{index}" in PYTHON_SKIPPED:
        pytest.skip(PYTHON_SKIPPED[f"{doc}:{index}"])
    shutil.copy(next((synthetic_data_dir / "eth/test").glob("*.txt")), tmp_path / "my_tracks.txt")
    seconds_csv(tmp_path / "my_tracks.csv")  # the README loop's tracker CSV
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(code, f"{doc}, Python block {index}", "exec"), namespace)
