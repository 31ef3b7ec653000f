"""The README's Python examples run as written (with a tiny checkpoint under a shipped name,
on a tiny synthetic benchmark)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO


def _python_blocks() -> list[str]:
    """The README's Python examples: the robot's loop, then training and evaluation."""
    blocks = re.findall(r"```python\n(.*?)```", (REPO / "README.md").read_text(), re.S)
    assert len(blocks) == 2
    return blocks


def _tracker_csv(path: Path, hz: float, start_s: float, jitter_s: float = 0.0) -> None:
    """A tracker's CSV at ``hz``: five people walking, times from ``start_s`` (with jitter and
    one message in ten dropped when ``jitter_s``)."""
    rng = np.random.default_rng(1)
    times = start_s + np.arange(0.0, 12.0, 1.0 / hz)
    if jitter_s:
        times = np.sort(times + rng.uniform(-jitter_s, jitter_s, len(times)))
        times = times[rng.uniform(size=len(times)) > 0.1]
    rows = ["time_s,person,x_m,y_m"]
    for person in range(1, 6):
        start, velocity = rng.uniform(-3, 3, 2), rng.normal(0, 0.8, 2)
        for t in times:
            x, y = start + velocity * (t - start_s)
            rows.append(f"{t:.6f},{person},{x:.4f},{y:.4f}")
    path.write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize(
    ("hz", "start_s", "jitter_s"), [(30.0, 0.0, 0.0), (10.0, 1_700_000_000.0, 0.02)]
)
def test_readme_python_example_runs(
    tiny_checkpoints: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    hz: float,
    start_s: float,
    jitter_s: float,
) -> None:
    """Verbatim on a 30 fps recording in seconds and on a 10 Hz tracker file in Unix seconds
    with jitter and dropped messages."""
    code, _ = _python_blocks()
    _tracker_csv(tmp_path / "my_tracks.csv", hz, start_s, jitter_s)
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
    # Progress by default, without a terminal too: what is trained, then each epoch's line.
    assert "training grouptron on eth" in printed and "epoch 2/2: loss" in printed
    assert "grouptron ml FDE" in printed and "grouptron best-of-20 FDE" in printed
    assert "constant-velocity - FDE" in printed and "None" not in printed
