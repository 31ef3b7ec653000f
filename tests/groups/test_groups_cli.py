"""`grouptron groups detect` and `grouptron groups evaluate` on a hand-made recording."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from grouptron.cli import main
from tests.conftest import write_tracks


def two_pairs(path: Path) -> Path:
    """Pedestrians 1 and 2 walk east side by side; 3 and 4 walk west together, far away."""
    rows = []
    for step in range(20):
        x = 0.5 * step
        rows += [(step * 10, 1, x, 0.0), (step * 10, 2, x, 0.6)]
        rows += [(step * 10, 3, 20 - x, 8.0), (step * 10, 4, 20 - x, 8.7)]
    return write_tracks(path, rows)


def test_detect_writes_groups_and_a_plot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = two_pairs(tmp_path / "pairs.txt")
    out, plot = tmp_path / "groups.csv", tmp_path / "groups.png"
    assert (
        main(
            [
                "groups",
                "detect",
                "--tracks",
                str(tracks),
                "--out",
                str(out),
                "--plot",
                str(plot),
                "--frame",
                "100",
            ]
        )
        == 0
    )
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 80 and set(rows[0]) == {"frame", "id", "group"}
    at_100 = {int(r["id"]): int(r["group"]) for r in rows if r["frame"] == "100"}
    assert at_100[1] == at_100[2] != at_100[3] == at_100[4]
    assert plot.stat().st_size > 10_000
    assert "frame 100" in capsys.readouterr().out


def evaluate_json(capsys: pytest.CaptureFixture[str], *argv: str) -> list[dict]:
    assert main(["groups", "evaluate", *argv, "--format", "json"]) == 0
    return json.loads(capsys.readouterr().out)["results"]


def test_evaluate_against_labels(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tracks = two_pairs(tmp_path / "pairs.txt")
    labels = tmp_path / "groups.txt"
    labels.write_text("1 2\n3 4\n")
    results = evaluate_json(capsys, "--tracks", str(tracks), "--labels", str(labels))
    assert {r["scope"] for r in results} == {"scene", "per_ego"}
    for row in results:
        assert {"pair_precision", "pair_recall", "pair_f1", "dice"} <= set(row)
        assert row["pair_f1"] == pytest.approx(1.0) and row["dice"] == pytest.approx(1.0)
    # With the ids renamed through a map the result is the same.
    id_map = tmp_path / "map.csv"
    id_map.write_text("track_id,label_id\n1,11\n2,12\n3,13\n4,14\n")
    labels.write_text("11 12\n13 14\n")
    mapped = evaluate_json(
        capsys, "--tracks", str(tracks), "--labels", str(labels), "--id-map", str(id_map)
    )
    assert all(r["pair_f1"] == pytest.approx(1.0) for r in mapped)


def test_bad_label_file_is_a_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = two_pairs(tmp_path / "pairs.txt")
    labels = tmp_path / "groups.txt"
    labels.write_text("1 two\n")
    assert main(["groups", "evaluate", "--tracks", str(tracks), "--labels", str(labels)]) == 2
    assert "groups.txt:1: expected pedestrian ids" in capsys.readouterr().err


def test_the_threshold_rule_leaves_strangers_alone_where_c_of_n_merges_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two walking pairs and two strangers standing 2.5 m apart: C(N) = 3 groups of 6 people
    must merge someone; the threshold rule finds the labelled groups, and so does the learned
    detector (the default)."""
    rows = []
    for step in range(20):
        x = 0.5 * step
        rows += [(step * 10, 1, x, 0.0), (step * 10, 2, x, 0.6)]
        rows += [(step * 10, 3, 20 - x, 8.0), (step * 10, 4, 20 - x, 8.7)]
        rows += [(step * 10, 5, 5.0, 4.0), (step * 10, 6, 7.5, 4.0)]
    tracks = write_tracks(tmp_path / "strangers.txt", rows)
    labels = tmp_path / "groups.txt"
    labels.write_text("1 2\n3 4\n")
    by_rule = {}
    for rule in ("threshold", "count"):
        results = evaluate_json(
            capsys, "--tracks", str(tracks), "--labels", str(labels), "--rule", rule
        )
        scene = next(r for r in results if r["scope"] == "scene")
        assert scene["rule"] == rule
        by_rule[rule] = scene["pair_f1"]
    assert by_rule["threshold"] == pytest.approx(1.0)
    assert by_rule["count"] < 0.9
    results = evaluate_json(capsys, "--tracks", str(tracks), "--labels", str(labels))
    scene = next(r for r in results if r["scope"] == "scene")
    assert scene["detector"] == "learned" and scene["rule"] == "learned"
    assert scene["pair_f1"] == pytest.approx(1.0)
    out = tmp_path / "groups.csv"
    assert main(["groups", "detect", "--tracks", str(tracks), "--out", str(out)]) == 0
    at_100 = {
        int(r["id"]): int(r["group"]) for r in csv.DictReader(out.open()) if r["frame"] == "100"
    }
    assert len({at_100[5], at_100[6], at_100[1], at_100[3]}) == 4 and at_100[1] == at_100[2]
