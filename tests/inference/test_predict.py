"""Forecasting track files: coordinates, frames and agreement with the evaluator."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.datasets.dataset import load_part, load_scenes
from grouptron.data.datasets.locate import split_files
from grouptron.evaluation.evaluate import evaluate_model
from grouptron.groups.cache import load_groups
from grouptron.inference.tracks import forecast_scene
from grouptron.model.checkpoint import load_trained_model
from tests.conftest import REPO, write_tracks


@pytest.mark.parametrize("model_name", ["trajectron++", "grouptron"])
def test_ml_forecast_reproduces_the_evaluator(
    tiny_checkpoints: Path, synthetic_data_dir: Path, model_name: str
) -> None:
    path = tiny_checkpoints / f"{model_name}-eth-central/best.safetensors"
    model, config = load_trained_model(path)
    (scene,) = load_scenes(split_files(synthetic_data_dir, "eth", "test"), config.data)
    forecast = forecast_scene(model, config, scene)
    # Forecasts are made wherever 8 steps are observed, also without a known future.
    table = np.loadtxt(split_files(synthetic_data_dir, "eth", "test")[0])
    position = {(int(f), int(i)): (x, y) for f, i, x, y in table}
    has_future = np.array(
        [
            all((int(f + 10 * k), int(p)) in position for k in range(1, 13))
            for f, p in zip(forecast.frames, forecast.ids, strict=True)
        ]
    )
    assert has_future.any() and not has_future.all()
    # Where the file has the future, the truth is the file's own positions k steps later.
    truth = np.array(
        [
            [position[(int(f + 10 * k), int(p))] for k in range(1, 13)]
            for f, p in zip(forecast.frames[has_future], forecast.ids[has_future], strict=True)
        ]
    )  # (S, 12, 2)
    error = np.linalg.norm(forecast.point[has_future] - truth, axis=-1)  # (S, 12)
    test = load_part(synthetic_data_dir, "eth", "test", config.data)
    groups = None
    if model_name == "grouptron":
        groups = load_groups(
            synthetic_data_dir,
            "eth",
            "test",
            config.data,
            groups=config.groups,
            samples=test.samples,
        )
    (scores,) = evaluate_model(model, config, test.samples, ("ml",), groups=groups)
    assert len(truth) == scores.samples
    assert error.mean() == pytest.approx(scores.ade, abs=1e-3)  # file has 3 decimals
    assert error[:, -1].mean() == pytest.approx(scores.fde, abs=1e-3)


def test_predict_command_writes_point_and_sample_rows(
    tiny_checkpoints: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = [(100 + 10 * s, 7, 1.0 + 0.5 * s, -2.0) for s in range(9)]
    rows += [(100 + 10 * s, 8, 1.0 + 0.5 * s, 0.0) for s in range(3, 9)]
    tracks = write_tracks(tmp_path / "walk.txt", rows)
    checkpoint = str(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    common = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--quiet"]
    out = tmp_path / "own.csv"
    assert main([*common, "--out", str(out)]) == 0
    with out.open() as handle:
        own = list(csv.DictReader(handle))
    # Pedestrian 7 has 8 observed steps at frames 170 and 180; pedestrian 8 never does.
    assert [(r["frame"], r["id"]) for r in own[::12]] == [("170", "7"), ("180", "7")]
    assert [int(r["step"]) for r in own[:12]] == list(range(1, 13))
    assert all(abs(float(r["x_m"])) < 60 and abs(float(r["y_m"]) + 2) < 30 for r in own)
    assert [float(r["t_s"]) for r in own[::12]] == [170 / 25, 180 / 25]  # its own seconds
    out = tmp_path / "samples.csv"
    assert main([*common, "--out", str(out), "--forecast", "samples", "--samples", "3"]) == 0
    with out.open() as handle:
        drawn = list(csv.DictReader(handle))
    assert len(drawn) == 2 * 3 * 12 and {r["sample"] for r in drawn} == {"0", "1", "2"}
    capsys.readouterr()
    # The default is the model's own point forecast: the argmax latent for plain Trajectron++ or
    # Grouptron; the others give the same rows at other positions.
    for mode in ("ml-argmax", "mean", "ml"):
        out = tmp_path / f"{mode}.csv"
        assert main([*common, "--out", str(out), "--forecast", mode]) == 0
        with out.open() as handle:
            point = list(csv.DictReader(handle))
        assert [(r["frame"], r["id"], r["step"]) for r in point] == [
            (r["frame"], r["id"], r["step"]) for r in own
        ]
        assert ([r["x_m"] for r in point] == [r["x_m"] for r in own]) == (mode == "ml-argmax")
    # --mode, the option's older name, still works and says on standard error what it is now.
    capsys.readouterr()
    older = tmp_path / "older.csv"
    assert main([*common, "--out", str(older), "--mode", "mean"]) == 0
    assert older.read_text() == (tmp_path / "mean.csv").read_text()
    assert "grouptron: --mode is now called --forecast" in capsys.readouterr().err
    assert main([*common, "--out", str(tmp_path / "default.csv")]) == 0
    assert "central derivatives, ml-argmax)" in capsys.readouterr().out


def test_predict_refuses_short_tracks_and_missing_files(
    tiny_checkpoints: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = write_tracks(tmp_path / "short.txt", [(10 * s, 1, 0.1 * s, 0.0) for s in range(5)])
    checkpoint = str(tiny_checkpoints / "trajectron++-eth-central/best.safetensors")
    common = ["predict", "--checkpoint", checkpoint, "--out", str(tmp_path / "o.csv")]
    assert main([*common, "--tracks", str(tracks)]) == 2
    assert "nothing to forecast" in capsys.readouterr().err
    assert main([*common, "--tracks", str(tmp_path / "missing.txt")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    folder_out = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--out"]
    assert main([*folder_out, str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.realdata
def test_shipped_checkpoint_csv_reproduces_the_evaluator_on_eth(
    eth_ucy_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    checkpoint = REPO / "checkpoints/trajectron++-eth-central/best.safetensors"
    if not checkpoint.exists():
        pytest.skip("shipped checkpoints not present")
    tracks = eth_ucy_dir / "eth/test/biwi_eth.txt"
    out = tmp_path / "eth.csv"
    predict = ["predict", "--checkpoint", str(checkpoint), "--tracks", str(tracks), "--quiet"]
    assert main([*predict, "--out", str(out), "--forecast", "ml"]) == 0  # the evaluator's default
    capsys.readouterr()
    evaluate = ["evaluate", "--checkpoint", str(checkpoint), "--data-dir", str(eth_ucy_dir)]
    assert main([*evaluate, "--quiet", "--format", "json", "--mode", "ml"]) == 0
    scores, _ = json.loads(capsys.readouterr().out)["results"]  # and constant velocity
    # Score the CSV against the file itself, wherever the file has all 12 future positions.
    observed = np.loadtxt(tracks)
    truth = {(int(f), float(i)): (x, y) for f, i, x, y in observed}
    rows = np.loadtxt(out, delimiter=",", skiprows=1)[:, :5]  # frame, id, step, x_m, y_m
    future = [truth.get((int(f + 10 * k), float(i))) for f, i, k, _, _ in rows]
    error = np.array([np.hypot(x - t[0], y - t[1]) if t else np.nan for (*_, x, y), t in
                      zip(rows, future, strict=True)]).reshape(-1, 12)  # fmt: skip
    complete = ~np.isnan(error).any(axis=1)
    assert complete.sum() == scores["samples"] == 364
    assert error[complete].mean() == pytest.approx(scores["ade"], abs=1e-4)
    assert error[complete, -1].mean() == pytest.approx(scores["fde"], abs=1e-4)


def test_without_a_checkpoint_the_default_model_forecasts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
    from grouptron.inference.predictor import Predictor

    predictor = Predictor.from_checkpoint()
    assert predictor.config.data.derivatives == "backward"  # made for live tracks
    assert Path(predictor.source).parent.name == DEFAULT_CHECKPOINT
    # its own point forecast, stored with it (campaign/point_forecast.py): ml of the 2 likeliest
    assert (predictor.point_forecast_name, predictor.decoded_latent_values) == ("ml-top2", 2)
    rows = [(10 * s, p, 0.4 * s, 1.5 * p) for s in range(9) for p in range(2)]
    tracks = write_tracks(tmp_path / "pair.txt", rows)
    out = tmp_path / "f.csv"
    assert main(["predict", "--tracks", str(tracks), "--out", str(out), "--quiet"]) == 0
    with out.open() as handle:
        assert len(list(csv.DictReader(handle))) == 2 * 2 * 12  # 2 walkers, 2 frames with 8 steps
    assert "look-ahead" not in capsys.readouterr().err


def test_forecast_rows_carry_the_files_own_frames_and_seconds(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    """A 16 fps file (0.4 s is 6.4 frames) and the same tracks in Unix seconds: ``frame`` is
    the file's nearest frame, ``t_s`` its own time, and plot takes either."""
    rng = np.random.default_rng(0)
    frames = np.arange(0, 16 * 12)  # 12 s at 16 fps
    rows = [
        (p, f, 0.8 * f / 16 + p, 0.5 * p + 0.01 * rng.normal()) for p in (1, 2, 3) for f in frames
    ]
    sixteen = tmp_path / "sixteen.txt"
    np.savetxt(sixteen, rows, fmt="%.4f")
    seconds = tmp_path / "seconds.csv"
    start = 1_700_000_000.0
    np.savetxt(seconds, [(start + f / 16, p, x, y) for p, f, x, y in rows], fmt="%.4f",
               delimiter=",")  # fmt: skip
    checkpoint = ["--checkpoint", str(tiny_checkpoints / "grouptron-eth-backward"), "--quiet"]
    out = tmp_path / "f.csv"
    assert main(["predict", "--tracks", str(sixteen), "--columns", "id,frame,x,y", "--fps",
                 "16", "--out", str(out), *checkpoint]) == 0  # fmt: skip
    with out.open() as handle:
        by_frame = list(csv.DictReader(handle))
    own_frames = np.array([float(r["frame"]) for r in by_frame])
    t_s = np.array([float(r["t_s"]) for r in by_frame])
    assert np.all(np.abs(own_frames / 16 - t_s) <= 1 / 32 + 1e-6)  # the nearest frame
    assert np.allclose(np.diff(np.unique(t_s)), 0.4)
    assert main(["predict", "--tracks", str(seconds), "--columns", "t,id,x,y",
                 "--out", str(out), *checkpoint]) == 0  # fmt: skip
    with out.open() as handle:
        by_time = list(csv.DictReader(handle))
    np.testing.assert_allclose([float(r["t_s"]) - start for r in by_time], t_s, atol=1e-3)
    # Each forecast joins back to the input row it was made from: by (id, frame) in the 16 fps
    # file (its nearest frame), by (id, t_s) in a 10 Hz tracker file in seconds (exactly).
    inputs_f = {(int(p), int(f)) for p, f, _, _ in rows}
    assert all((int(r["id"]), int(r["frame"])) in inputs_f for r in by_frame)
    tracker = tmp_path / "tracker.csv"
    ten_hz = [(start + j / 10, p, 0.8 * j / 10 + p, 0.5 * p) for p in (1, 2, 3) for j in range(120)]
    np.savetxt(tracker, ten_hz, fmt="%.4f", delimiter=",")
    assert main(["predict", "--tracks", str(tracker), "--columns", "t,id,x,y",
                 "--out", str(out), *checkpoint]) == 0  # fmt: skip
    with out.open() as handle:
        joined = list(csv.DictReader(handle))
    inputs_t = {(int(p), round(t, 3)) for t, p, _, _ in ten_hz}
    assert joined and all((int(r["id"]), round(float(r["t_s"]), 3)) in inputs_t for r in joined)
    picture = tmp_path / "p.png"
    plot = ["plot", "--out", str(picture), *checkpoint]
    at = str(int(own_frames[len(own_frames) // 2]))
    assert main([*plot, "--tracks", str(sixteen), "--columns", "id,frame,x,y", "--fps", "16",
                 "--frame", at]) == 0  # fmt: skip
    assert main([*plot, "--tracks", str(seconds), "--columns", "t,id,x,y",
                 "--time", f"{start + t_s[0]:.3f}"]) == 0  # fmt: skip
    assert main([*plot, "--tracks", str(seconds), "--columns", "t,id,x,y", "--time", "1",
                 "--frame", "3"]) == 2  # fmt: skip
