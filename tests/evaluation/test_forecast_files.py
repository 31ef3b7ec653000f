"""Forecast files scored as a checkpoint is: predict's own output gives evaluate's numbers, a
file that lacks samples is refused with their count, samples are scored best-of-K."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.formats.forecast_file import read_forecast_file
from grouptron.errors import DataFormatError
from tests.conftest import REPO


def _rows(capsys: pytest.CaptureFixture[str]) -> list[dict]:
    return json.loads(capsys.readouterr().out)["results"]


def _scores(args: list[str], capsys: pytest.CaptureFixture[str]) -> list[dict]:
    capsys.readouterr()  # what came before
    assert main(["evaluate", *args, "--format", "json", "--quiet"]) == 0
    return _rows(capsys)


def _predicted(checkpoint: str, tracks: str, out: Path, *forecast: str) -> Path:
    """``out``, predict's file of ``checkpoint``'s forecasts of ``tracks`` (``forecast``: its
    --forecast and further options)."""
    predict = ["predict", "--checkpoint", checkpoint, "--tracks", tracks, "--quiet"]
    assert main([*predict, "--out", str(out), *forecast]) == 0
    return out


@pytest.mark.parametrize("suffix", [".csv", ".ndjson"])
def test_predicts_own_file_scores_as_the_checkpoint(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    suffix: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    checkpoint = str(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    out = tmp_path / f"scene5{suffix}"
    _predicted(checkpoint, tracks, out, "--forecast", "ml")
    data = ["--split", "eth", "--data-dir", str(synthetic_data_dir)]
    model, baseline = _scores(["--checkpoint", checkpoint, "--mode", "ml", *data], capsys)
    ours, beside = _scores(["--forecasts", str(out), *data], capsys)
    assert (ours["model"], ours["mode"], ours["samples"]) == ("scene5", "ml", model["samples"])
    assert ours["ade"] == pytest.approx(model["ade"], abs=1e-6)
    assert ours["fde"] == pytest.approx(model["fde"], abs=1e-6)
    assert beside == baseline  # constant velocity on the same samples


def test_missing_samples_are_counted_and_refused_unless_allowed(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    checkpoint = str(tiny_checkpoints / "trajectron++-eth-central")
    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    full = tmp_path / "full.csv"
    _predicted(checkpoint, tracks, full, "--forecast", "ml")
    lines = full.read_text().splitlines()
    frames = sorted({int(line.split(",")[0]) for line in lines[1:]})
    cut = tmp_path / "cut.csv"  # without the forecasts made at the first frame
    cut.write_text(
        "\n".join([lines[0], *(r for r in lines[1:] if int(r.split(",")[0]) > frames[0])])
    )
    data = ["--split", "eth", "--data-dir", str(synthetic_data_dir)]
    (everything, _) = _scores(["--forecasts", str(full), *data], capsys)
    capsys.readouterr()
    assert main(["evaluate", "--forecasts", str(cut), *data]) == 2
    error = capsys.readouterr().err
    missing = int(re.search(r"cut.csv: (\d+) of the \d+ test samples have no forecast", error)[1])
    assert 0 < missing < everything["samples"] and "--allow-missing" in error
    allowed, baseline = _scores(["--forecasts", str(cut), "--allow-missing", *data], capsys)
    assert allowed["samples"] == baseline["samples"] == everything["samples"] - missing


def test_sampled_futures_are_scored_best_of_k(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    checkpoint = str(tiny_checkpoints / "trajectron++-eth-central")
    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    out = tmp_path / "samples.csv"
    _predicted(checkpoint, tracks, out, "--forecast", "samples", "--samples", "5")
    data = ["--split", "eth", "--data-dir", str(synthetic_data_dir), "--name", "mine"]
    best_of_5, _ = _scores(["--forecasts", str(out), *data], capsys)  # all of them, by default
    best_of_1, _ = _scores(["--forecasts", str(out), "--mode", "best-of-1", *data], capsys)
    assert (best_of_5["model"], best_of_5["mode"]) == ("mine", "best-of-5")
    assert best_of_5["fde"] <= best_of_1["fde"]
    assert main(["evaluate", "--forecasts", str(out), "--mode", "best-of-20", *data]) == 2
    assert "holds 5 sampled futures per forecast" in capsys.readouterr().err
    assert main(["evaluate", "--forecasts", str(out), "--mode", "nll", *data]) == 2
    assert "need a --checkpoint" in capsys.readouterr().err


def test_files_without_the_columns_are_refused_in_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("frame,id,x_m,y_m\n0,1,0.0,0.0\n")
    with pytest.raises(DataFormatError, match="step missing from its header"):
        read_forecast_file(bad)
    zero = tmp_path / "zero.csv"
    zero.write_text("frame,id,step,x_m,y_m\n0,1,0,0.0,0.0\n")
    with pytest.raises(DataFormatError, match="steps count from 1"):
        read_forecast_file(zero)


@pytest.mark.realdata
def test_shipped_checkpoints_csv_scores_as_it_does_to_a_micrometre(
    eth_ucy_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    checkpoint = REPO / "checkpoints/trajectron++-eth-central/best.safetensors"
    if not checkpoint.exists():
        pytest.skip("shipped checkpoints not present")
    out = tmp_path / "eth.csv"
    tracks = str(eth_ucy_dir / "eth/test/biwi_eth.txt")
    _predicted(str(checkpoint), tracks, out, "--forecast", "ml")
    data = ["--split", "eth", "--data-dir", str(eth_ucy_dir)]
    model, _ = _scores(["--checkpoint", str(checkpoint), "--mode", "ml", *data], capsys)
    ours, _ = _scores(["--forecasts", str(out), *data], capsys)
    assert ours["samples"] == model["samples"] == 364
    assert abs(ours["ade"] - model["ade"]) < 1e-6 and abs(ours["fde"] - model["fde"]) < 1e-6
    assert np.isfinite(ours["fde"])


def test_files_need_their_split_and_each_position_once(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    checkpoint = str(tiny_checkpoints / "trajectron++-eth-central")
    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    out = tmp_path / "scene5.csv"
    _predicted(checkpoint, tracks, out, "--forecast", "ml")
    data = ["--data-dir", str(synthetic_data_dir)]
    capsys.readouterr()
    assert main(["evaluate", "--forecasts", str(out), *data]) == 2
    assert "name them with --split" in capsys.readouterr().err
    lines = out.read_text().splitlines()
    twice = tmp_path / "twice.csv"
    twice.write_text("\n".join([*lines, lines[1]]) + "\n")
    assert main(["evaluate", "--forecasts", str(twice), "--split", "eth", *data]) == 2
    assert "a position given twice" in capsys.readouterr().err


def test_forecasts_of_a_recording_score_as_the_checkpoint_there(
    tiny_checkpoints: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A recording in its own layout (16 frames a second, centimetres): predict's file of it
    is found by the file's own frame numbers."""
    rng = np.random.default_rng(0)
    frames = np.arange(16 * 12)  # 12 s at 16 frames a second
    rows = [
        (p, f, 100 * (0.9 * f / 16 + p), 100 * (0.6 * p + 0.01 * rng.normal()), 0.0)
        for p in range(6)
        for f in frames
    ]
    recording = tmp_path / "corridor.txt"
    np.savetxt(recording, rows, fmt="%.3f")
    layout = ["--columns", "id,frame,x,y,z", "--fps", "16", "--units", "cm"]
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    out = tmp_path / "corridor.csv"
    _predicted(checkpoint, str(recording), out, "--forecast", "ml", *layout)
    on_tracks = ["--tracks", str(recording), *layout]
    model = _scores(["--checkpoint", checkpoint, "--mode", "ml", *on_tracks], capsys)
    ours = _scores(["--forecasts", str(out), *on_tracks], capsys)
    assert [r["samples"] for r in ours] == [r["samples"] for r in model]
    assert ours[0]["fde"] == pytest.approx(model[0]["fde"], abs=1e-6)
    assert ours[0]["ade"] == pytest.approx(model[0]["ade"], abs=1e-6)
