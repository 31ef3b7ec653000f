"""grouptron compare: two models on the same test samples, B - A with intervals; a model
against its own forecast file differs by nothing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.workflows.compare import compare
from grouptron.workflows.evaluate_files import ForecastFiles


def test_two_checkpoints_differ_with_an_interval(
    tiny_checkpoints: Path, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = str(tiny_checkpoints / "trajectron++-eth-central")
    b = str(tiny_checkpoints / "grouptron-eth-central")
    data = ["--data-dir", str(synthetic_data_dir)]
    assert main(["compare", a, b, "--mode", "ml", "--format", "json", *data]) == 0
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert row["split"] == "eth" and row["modes"] == ["ml", "ml"] and row["samples"] > 0
    fde = row["difference"]["fde"]
    assert fde["low"] <= fde["mean"] <= fde["high"]
    assert fde["mean"] == pytest.approx(row["b"]["fde"] - row["a"]["fde"])
    assert main(["compare", a, b, *data]) == 0
    assert "B - A FDE m (95% interval)" in capsys.readouterr().out


def test_scene_metrics_are_compared_paired_too(
    tiny_checkpoints: Path, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = str(tiny_checkpoints / "trajectron++-eth-central")
    b = str(tiny_checkpoints / "grouptron-eth-central")
    data = ["--data-dir", str(synthetic_data_dir), "--mode", "best-of-20"]
    metrics = ["--metrics", "col-i,jfde", "--format", "json"]
    assert main(["compare", a, b, *data, *metrics]) == 0
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert set(row["metrics"]) == {"col-i", "jfde"}
    jfde = row["metrics"]["jfde"]
    assert jfde["difference"]["mean"] == pytest.approx(jfde["b"] - jfde["a"])
    assert jfde["b"] >= row["b"]["fde"] - 1e-12  # chosen per moment: no better than per person
    assert main(["compare", a, a, *data, *metrics]) == 0  # a model against itself: nothing
    (same,) = json.loads(capsys.readouterr().out)["rows"]
    assert same["metrics"]["col-i"]["difference"] == {"mean": 0.0, "low": 0.0, "high": 0.0}


def test_a_model_and_its_own_forecast_file_do_not_differ(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    out = tmp_path / "mine.csv"
    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    predict = ["predict", "--checkpoint", checkpoint, "--tracks", tracks, "--forecast", "ml"]
    assert main([*predict, "--out", str(out), "--quiet"]) == 0
    (row,) = compare(checkpoint, ForecastFiles((out,)), mode="ml", data_dir=synthetic_data_dir)
    assert abs(row.fde.mean) < 1e-6 and abs(row.ade.mean) < 1e-6
    assert np.allclose(row.a, row.b, atol=1e-6)


def test_files_alone_need_a_split(tmp_path: Path, synthetic_data_dir: Path) -> None:
    files = ForecastFiles((tmp_path / "a.csv",))
    with pytest.raises(GrouptronError, match="name no benchmark split"):
        compare(files, files, data_dir=synthetic_data_dir)
