"""``--learn`` on the command line: predict keeps a site, evaluate scores the learning."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from grouptron.cli import main
from grouptron.inference.predictor import Predictor
from tests.conftest import synthetic_recording

ROUNDS = ["--learn", "--learn-round-s", "4", "--learn-steps", "5"]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("site") / "site.txt"
    return synthetic_recording(path, seed=11, pedestrians=14, steps=90)


def test_predict_learns_and_keeps_the_site(
    tiny_checkpoints: Path, site: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    kept = tmp_path / "site"
    argv = ["predict", "--tracks", str(site), "--checkpoint", checkpoint, "--min-points", "2"]
    assert main([*argv, "--out", str(tmp_path / "f.csv"), *ROUNDS, "--save-site", str(kept)]) == 0
    assert "learning: " in capsys.readouterr().err
    card = json.loads((kept / "site.json").read_text())
    assert card["rounds"] >= 1 and card["minutes"] > 0
    Predictor.from_checkpoint(kept)  # loads like any checkpoint


def test_save_site_without_learn_is_one_line(site: Path, tmp_path: Path, capsys) -> None:
    argv = ["predict", "--tracks", str(site), "--out", str(tmp_path / "f.csv")]
    assert main([*argv, "--save-site", str(tmp_path / "s")]) == 2
    assert "add --learn" in capsys.readouterr().err


def test_evaluate_learn_scores_the_later_half_beside_the_fixed_model(
    tiny_checkpoints: Path, site: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    argv = ["evaluate", "--tracks", str(site), str(site), "--checkpoint", checkpoint, *ROUNDS]
    assert main([*argv, "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["recording"] for r in rows] == ["site.txt", "site.txt", "pooled"]
    assert rows[0]["learning"]["rounds"] >= 1
    assert rows[0]["fixed_fde"] == pytest.approx(rows[2]["fixed_fde"])  # the same file twice
    assert rows[0]["difference_interval"][0] <= rows[0]["difference"]


def test_evaluate_learn_needs_track_files(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", "--learn"]) == 2
    assert "--tracks" in capsys.readouterr().err
