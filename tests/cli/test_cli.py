"""The command line: help everywhere, one-line errors with exit code 2, real tables."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from grouptron.cli import main
from tests.conftest import write_tracks
from tests.helpers.models import TINY_MODEL

COMMANDS = [
    [],
    ["data"],
    ["data", "fetch"],
    ["data", "stats"],
    ["evaluate"],
    ["train"],
    ["groups"],
    ["groups", "detect"],
    ["groups", "evaluate"],
]


@pytest.mark.parametrize("command", COMMANDS)
def test_help_explains_with_an_example(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as info:
        main([*command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "usage: grouptron" in out and "examples:" in out


def run_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert "Traceback" not in "\n".join(err)
    assert err[-1].startswith("grouptron: error: ")
    return err[-1]


def test_bad_track_file_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "eth" / "test"
    folder.mkdir(parents=True)
    (folder / "broken.txt").write_text("0\t1\t0.0\t0.0\n10\t1\tfoo\t0.0\n")
    message = run_error(
        ["evaluate", "--model", "constant-velocity", "--split", "eth", "--data-dir", str(tmp_path)],
        capsys,
    )
    assert f"{folder / 'broken.txt'}:2: x is not a number" in message


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["evaluate", "--model", "constant-velocity", "--split", "mars"], "unknown split"),
        (["evaluate", "--model", "oracle"], "invalid choice"),
        (
            ["evaluate", "--checkpoint", "x", "--model", "constant-velocity"],
            "give one of --checkpoint PATH, --forecasts FILE or --model constant-velocity",
        ),
        (["evaluate", "--checkpoint", "nowhere.safetensors"], "checkpoint not found"),
        (["train", "--split", "eth", "--epochs", "0"], "epochs"),
        (
            ["evaluate", "--model", "constant-velocity", "--split", "eth", "--subset", "univ-40"],
            "needs --split univ",
        ),
        (
            ["evaluate", "--model", "constant-velocity", "--split", "univ", "--subset", "dense"],
            "expected univ-N",
        ),
        (["data", "stats", "--univ-n", "forty"], "comma-separated integers"),
        (["train", "--out", "r", "--resume", "--model", "grouptron"], "--model would be ignored"),
        (["train", "--out", "nowhere", "--resume"], "no last.safetensors to resume"),
    ],
)
def test_usage_errors(argv: list[str], fragment: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert fragment in run_error(argv, capsys)


CV_ETH = ["evaluate", "--model", "constant-velocity", "--split", "eth"]


def test_gap_policy_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rows = [(s * 10, 1, 0.4 * s, 0.0) for s in range(45) if s != 9]
    write_tracks(tmp_path / "eth/test/gap.txt", rows)
    argv = [*CV_ETH, "--data-dir", str(tmp_path)]
    assert main([*argv, "--no-cache"]) == 0  # split into steps 0..8 and 10..44: t = 17..32
    assert "16" in capsys.readouterr().out.splitlines()[2].split()
    assert "has a gap between frames 80 and 100" in run_error([*argv, "--on-gap", "error"], capsys)


def test_no_test_samples_is_an_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_tracks(tmp_path / "eth/test/short.txt", [(s * 10, 1, 0.4 * s, 0.0) for s in range(5)])
    assert "no test samples" in run_error([*CV_ETH, "--data-dir", str(tmp_path)], capsys)


def json_rows(argv: list[str], capsys: pytest.CaptureFixture[str]) -> list[dict]:
    """The model's rows of an evaluation (constant velocity, scored beside it, left out)."""
    assert main([*argv, "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert rows[-1]["model"] == "constant-velocity"
    return [r for r in rows if r["model"] != "constant-velocity"] or rows


def test_train_then_evaluate_a_checkpoint(
    synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.json"
    config.write_text(json.dumps({"model": TINY_MODEL, "train": {"batch_size": 64}}))
    out = tmp_path / "run"
    common = ["--data-dir", str(synthetic_data_dir), "--quiet"]
    argv = ["train", "--split", "eth", "--epochs", "1", "--config", str(config), "--out", str(out)]
    assert main([*argv, *common]) == 0
    printed = capsys.readouterr().out
    assert "done: 1 epochs" in printed and "(backward derivatives)" in printed  # causal default
    # Resuming keeps the stored configuration (no --config needed) and may extend the run.
    resume = ["train", "--split", "eth", "--epochs", "2", "--out", str(out), "--resume"]
    assert main([*resume, *common]) == 0
    printed = capsys.readouterr().out
    assert "done: 2 epochs" in printed and "(on the per-epoch subset)" in printed
    assert "chosen on the whole validation part" in printed
    assert len((out / "metrics.jsonl").read_text().splitlines()) == 2

    evaluate = ["evaluate", "--checkpoint", str(out / "best.safetensors"), *common]
    rows = json_rows([*evaluate, "--mode", "ml,ml-argmax,mean,best-of-20"], capsys)
    assert [r["mode"] for r in rows] == ["ml", "ml-argmax", "mean", "best-of-20"]
    assert all(r["split"] == "eth" and r["model"] == "trajectron++" for r in rows)
    assert rows[3]["ade"] <= rows[0]["ade"]  # the best of 20 beats a single guess
    (nll,) = json_rows([*evaluate, "--mode", "nll"], capsys)
    assert nll["ade"] is None and math.isfinite(nll["nll"]) and nll["nll"] < 20.0
    message = run_error([*evaluate, "--derivatives", "central"], capsys)
    assert "trained with backward derivatives" in message


def test_missing_data_points_to_fetch(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    message = run_error(["data", "stats", "--split", "eth", "--data-dir", str(tmp_path)], capsys)
    assert "grouptron data fetch" in message


def test_evaluate_on_a_tiny_split(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rows = [(s * 10, p, 0.4 * s, float(p)) for s in range(25) for p in range(2)]
    write_tracks(tmp_path / "eth/test/a.txt", rows)
    (row,) = json_rows([*CV_ETH, "--data-dir", str(tmp_path)], capsys)
    expected = {
        "split": "eth",
        "model": "constant-velocity",
        "subset": None,
        "samples": 12,
        "ade": pytest.approx(0.0, abs=1e-6),
        "fde": pytest.approx(0.0, abs=1e-6),
        "displacement_per_step": pytest.approx([0.0] * 12, abs=1e-6),
        "derivatives": "central",
    }
    assert {k: row.get(k) for k in expected} == expected
    assert {"ade_ci", "fde_ci", "displacement_per_step_ci"} <= set(row)  # every mean's interval


@pytest.mark.realdata
def test_stats_json_shape(eth_ucy_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["data", "stats", "--data-dir", str(eth_ucy_dir), "--format", "json"]) == 0
    stats = json.loads(capsys.readouterr().out)
    assert list(stats) == ["eth", "hotel", "univ", "zara1", "zara2"]
    assert stats["eth"]["test_samples"] == 364
    assert stats["univ"]["univ_n"]["predicted"] == {"40": 3222, "45": 1596, "50": 572}
    assert stats["univ"]["univ_n"]["present"] == {"40": 16599, "45": 13115, "50": 8268}
    assert stats["univ"]["test_max_pedestrians_per_step"] == 75


@pytest.mark.realdata
def test_console_script_prints_the_constant_velocity_table(eth_ucy_dir: Path) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "grouptron.cli",
            "evaluate",
            "--model",
            "constant-velocity",
            "--split",
            "all",
            "--data-dir",
            str(eth_ucy_dir),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    lines = done.stdout.strip().splitlines()
    assert [line.split()[0] for line in lines[2:]] == [
        "eth",
        "hotel",
        "univ",
        "zara1",
        "zara2",
        "mean",
    ]
    column = lines[0].split().index("ADE")  # a row's words line up until the heading's unit
    ade_by_split = {line.split()[0]: float(line.split()[column]) for line in lines[2:]}
    # Constant velocity is a weak but sane baseline: metres, not kilometres, and not zero.
    assert all(0.1 < v < 2.0 for v in ade_by_split.values())


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (
            ["groups", "evaluate", "--tracks", "t.txt", "--labels", "l.txt", "--every", "0"],
            "positive integer",
        ),
        (["groups", "detect", "--tracks", "t.txt", "--frames-per-step", "-10"], "positive integer"),
        (["train", "--split", "eth", "--threads", "0"], "threads must be >= 1"),
        (["train", "--split", "eth", "--lr", "-1"], "learning_rate must be > 0"),
        (["train", "--split", "eth", "--device", "bogus"], "not a torch device"),
    ],
)
def test_bad_numbers_and_devices_are_refused_early(
    argv: list[str], fragment: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert fragment in run_error(argv, capsys)


def test_unwritable_output_is_a_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = write_tracks(
        tmp_path / "t.txt", [(s * 10, p, 0.4 * s, p) for s in range(9) for p in range(3)]
    )
    message = run_error(
        ["groups", "detect", "--tracks", str(tracks), "--out", str(tmp_path)], capsys
    )
    assert str(tmp_path) in message
