"""The commands that read a track file are library functions: from Python they write what
the command writes."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.formats.track_files import TrackFile
from grouptron.errors import GrouptronError
from grouptron.workflows.groups import DetectRequest, GroupRule, detect_groups, score_groups
from grouptron.workflows.predict import PredictRequest, predict_tracks
from tests.conftest import write_tracks

CHECKPOINT = Path(__file__).resolve().parents[1] / "golden" / "grouptron-univ-backward.safetensors"


def _walkers(tmp_path: Path) -> Path:
    """Six people walking straight for 30 steps, two pairs side by side."""
    rng = np.random.default_rng(3)
    rows = []
    for p in range(6):
        start = rng.uniform(0, 6, 2) + np.array([0.6 * (p % 2), 0.0])
        v = rng.uniform(-1, 1, 2)
        rows += [(10 * k, p, *(start + v * 0.4 * k)) for k in range(30)]
    return write_tracks(tmp_path / "walk.txt", sorted(rows))


def test_predict_writes_what_the_command_writes(tmp_path: Path) -> None:
    tracks = _walkers(tmp_path)
    out = tmp_path / "f.csv"
    argv = ["predict", "--checkpoint", str(CHECKPOINT), "--tracks", str(tracks), "--quiet"]
    assert main([*argv, "--out", str(out)]) == 0
    stream = io.StringIO()
    done = predict_tracks(PredictRequest(TrackFile(tracks), stream, CHECKPOINT))
    assert stream.getvalue() == out.read_text()
    assert done.count == len(out.read_text().splitlines()) - 1 and not done.scene_updates


def test_groups_are_detected_and_scored_from_python(tmp_path: Path, capsys) -> None:
    tracks = _walkers(tmp_path)
    assert main(["groups", "detect", "--tracks", str(tracks)]) == 0
    printed = capsys.readouterr().out.splitlines()[1:]
    detected = detect_groups(DetectRequest(TrackFile(tracks), frame=None))
    assert [",".join(map(str, row)) for row in detected.rows] == printed
    labels = tmp_path / "labels.txt"
    labels.write_text("0 1\n2 3\n")
    rows = score_groups(TrackFile(tracks), labels, GroupRule(linkage="all"))
    assert {(r.scope, r.config.linkage) for r in rows} == {
        (scope, linkage)
        for scope in ("scene", "per_ego")
        for linkage in ("single", "average", "complete")
    }
    with pytest.raises(GrouptronError, match="unknown linkage 'nearest'"):
        GroupRule(linkage="nearest").configs()  # type: ignore[arg-type]
