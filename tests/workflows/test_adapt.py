"""Site adaptation: the first minutes of a site's recordings adapt a checkpoint, the last ones
score it before and after, and the two never overlap."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.datasets.download import file_sha256
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.windows import cut_windows, step_window
from grouptron.errors import GrouptronError
from grouptron.workflows.adapt import ADAPTATION, AdaptRequest, adapt
from tests.conftest import synthetic_recording


def test_windows_cut_recordings_played_one_after_the_other() -> None:
    # 30 + 50 + 20 steps of 0.4 s = 40 s; the first 16 s and the last 10 s.
    windows = cut_windows([30, 50, 20], first_s=16.0, last_s=10.0, dt_s=0.4)
    assert windows.first == (30, 10, 0)  # all of the first, 10 steps of the second
    assert windows.last == (30, 45, 0)  # the last 5 steps of the second, all of the third
    assert windows.total_s == pytest.approx(40.0)


def test_a_step_window_keeps_the_rows_inside_and_their_frames(tmp_path: Path) -> None:
    table = read_tracks(synthetic_recording(tmp_path / "a.txt", 1, steps=40), 10)
    window = step_window(table, 10, 20)
    assert window is not None
    assert window.step.min() >= 0 and window.step.max() <= 9
    inside = (table.step >= 10) & (table.step < 20)
    assert np.array_equal(window.frame, table.frame[inside])
    assert np.array_equal(window.pos_m, table.pos_m[inside])
    assert step_window(table, 100, 200) is None


def _site(folder: Path) -> tuple[Path, Path]:
    """Two one-minute recordings of one site (150 steps each)."""
    first = synthetic_recording(folder / "monday.txt", 7, pedestrians=12, steps=150)
    second = synthetic_recording(folder / "tuesday.txt", 8, pedestrians=12, steps=150)
    return first, second


@pytest.mark.slow
def test_adaptation_scores_the_held_out_part_and_records_what_it_saw(
    tiny_checkpoints: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    monday, tuesday = _site(tmp_path)
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    request = AdaptRequest(
        files=(monday, tuesday), minutes=0.5, holdout_minutes=0.75, checkpoint=checkpoint,
        out=str(tmp_path / "adapted"), steps=4, batch_size=32, threads=1,
    )  # fmt: skip
    result = adapt(request)
    assert result.adapted_s == pytest.approx(30.0) and result.best.is_file()
    before, after, baseline = result.rows
    assert before.samples == after.samples == baseline.samples > 0  # the same held-out samples
    assert result.gain is not None
    assert result.gain.mean == pytest.approx(after.fde - before.fde)
    assert result.gain.low <= result.gain.mean <= result.gain.high
    record = json.loads((tmp_path / "adapted" / ADAPTATION).read_text())
    assert [(f["sha256"], f["adapted_until_s"]) for f in record["files"]] == [
        (file_sha256(monday), pytest.approx(30.0))
    ]  # tuesday was not adapted on
    with pytest.raises(
        GrouptronError, match=r"held-out part \(1 min\), which may not overlap, need more"
    ):
        adapt(AdaptRequest(files=(monday, tuesday), minutes=1.5, holdout_minutes=1.0))

    # evaluate names a file the adapted checkpoint saw, and only that one.
    adapted = str(result.best)
    with caplog.at_level(logging.WARNING, logger="grouptron"):
        assert main(["evaluate", "--tracks", str(tuesday), "--checkpoint", adapted]) == 0
        assert "adapted" not in caplog.text
        assert main(["evaluate", "--tracks", str(monday), "--checkpoint", adapted]) == 0
    assert "its first 30 s adapted" in caplog.text
    capsys.readouterr()

    argv = ["adapt", "--tracks", str(monday), str(tuesday), "--minutes", "0.5"]
    argv += ["--holdout-minutes", "0.75", "--checkpoint", checkpoint, "--steps", "2"]
    assert main([*argv, "--out", str(tmp_path / "again"), "--quiet", "--threads", "1"]) == 0
    printed = capsys.readouterr().out
    assert "adapted on 0.5 min" in printed and "FDE after minus before" in printed
    assert main([*argv[:5], "3", "--holdout-minutes", "0"]) == 2  # more than the recordings hold
    assert "(3 min) needs more than the recordings hold (1.9" in capsys.readouterr().err
