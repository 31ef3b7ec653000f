"""A training epoch's progress: lines without a terminal (the first after a few seconds, then
every half minute) saying the loss, samples per second and the time left."""

from __future__ import annotations

import io
from types import SimpleNamespace

import pytest

from grouptron.training import progress
from grouptron.training.progress import EpochProgress, duration


def test_durations_read_as_people_say_them() -> None:
    assert [duration(s) for s in (4.2, 65, 3725)] == ["4 s", "1 min 05 s", "1 h 02 min"]


def test_lines_come_early_then_every_half_minute(monkeypatch: pytest.MonkeyPatch) -> None:
    readings = [0.0, 1.0, 6.0, 20.0, 37.0, 40.0, 0.0, 50.0]  # start, then one per step
    clock = iter(readings)
    monkeypatch.setattr(progress, "time", SimpleNamespace(perf_counter=lambda: next(clock)))
    out = io.StringIO()
    shown = EpochProgress(1, 3, 10, shown=True, out=out)
    for _ in range(5):
        shown.step(256, 12.5)
    shown.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 2  # at 6 s (past the first 5 s), then at 37 s (30 s later)
    assert lines[0] == (
        "epoch 1/3: step 2/10, loss 12.5, 85 samples/s, about 24 s left in this epoch "
        "(1 min 24 s in all, validation not counted)"
    )
    quiet = io.StringIO()
    silent = EpochProgress(1, 1, 2, shown=False, out=quiet)
    silent.step(1, 1.0)
    assert quiet.getvalue() == ""
