"""Command-line behaviour shared by every command: global options, --config, --set."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import torch

from grouptron.cli import build_parser
from grouptron.cli.options import eval_modes
from grouptron.cli.train import experiment_from_args, parse_setting
from grouptron.errors import GrouptronError
from grouptron.point_forecast import PointForecast


@pytest.mark.parametrize(
    "argv",
    [
        ["-v", "data", "stats"],
        ["data", "stats", "-v"],
        ["data", "-v", "stats"],
        ["train", "--split", "eth", "--verbose"],
    ],
)
def test_verbose_is_accepted_before_and_after_the_command(argv: list[str]) -> None:
    assert build_parser().parse_args(argv).verbose is True


def test_verbose_defaults_to_off() -> None:
    assert build_parser().parse_args(["data", "stats"]).verbose is False


def _train_args(*extra: str):
    return build_parser().parse_args(["train", "--split", "eth", "--precision", "fp32", *extra])


def test_config_file_model_name_is_used_and_the_preset_applies(tmp_path: Path) -> None:
    """The --config trap: a file naming grouptron trained Trajectron++ without the eth preset."""
    path = tmp_path / "run.json"
    path.write_text(json.dumps({"model_name": "grouptron", "train": {"epochs": 3}}))
    config = experiment_from_args(_train_args("--config", str(path)))
    assert config.model_name == "grouptron"
    assert config.group_encoder.group_dim == 8  # eth preset of Grouptron
    assert config.train.epochs == 3
    explicit = experiment_from_args(_train_args("--config", str(path), "--model", "trajectron++"))
    assert explicit.model_name == "trajectron++"


def test_set_overrides_the_file_and_flags_override_set(tmp_path: Path) -> None:
    path = tmp_path / "run.json"
    path.write_text(json.dumps({"train": {"seed": 1, "epochs": 3}}))
    args = _train_args(
        "--config", str(path), "--set", "train.seed=2", "--set", "train.epochs=4", "--epochs", "5"
    )
    config = experiment_from_args(args)
    assert (config.train.seed, config.train.epochs) == (2, 5)


def test_set_parses_values_and_refuses_bad_keys() -> None:
    assert parse_setting("group_encoder.group_dim=32") == {"group_encoder": {"group_dim": 32}}
    assert parse_setting("data.derivatives=backward") == {"data": {"derivatives": "backward"}}
    with pytest.raises(GrouptronError, match=r"SECTION\.KEY=VALUE"):
        parse_setting("train.seed")
    with pytest.raises(GrouptronError, match="unknown TrainConfig keys: sed"):
        experiment_from_args(_train_args("--set", "train.sed=3"))


def test_report_by_default_scores_the_nll_on_a_capped_sample() -> None:
    """The full NLL of every test sample takes hours; the default report takes minutes."""
    assert build_parser().parse_args(["report"]).nll_max_samples == 300


def test_config_show_prints_the_effective_settings(capsys: pytest.CaptureFixture[str]) -> None:
    from grouptron.cli import main

    assert main(["config", "show", "--model", "grouptron", "--split", "eth"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["model_name"] == "grouptron" and shown["group_encoder"]["group_dim"] == 8
    assert main(["config", "show", "--set", "train.seed=3", "--changes"]) == 0
    assert "train.seed = 3" in capsys.readouterr().out.splitlines()


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("train.epoch=3", r"unknown TrainConfig keys: epoch \(did you mean epochs\?\)"),
        ("train.epochs=many", "TrainConfig.epochs must be int, not 'many'"),
        ("train.rotation_augmentation=1", "must be bool"),
        ("data.derivatives=forward", "must be one of 'central', 'backward'"),
        ("modle.latent_values=5", r"did you mean model\?"),
    ],
)
def test_wrong_settings_are_one_line_errors(
    setting: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from grouptron.cli import main

    assert main(["config", "show", "--set", setting]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err


@pytest.mark.skipif(
    torch.cuda.is_available(), reason="checks the message of a machine without CUDA"
)
@pytest.mark.parametrize(
    "command",
    [
        ["train", "--split", "eth"],
        ["evaluate", "--model", "constant-velocity"],
        ["predict", "--checkpoint", "C", "--tracks", "T", "--out", "o.csv"],
        ["plot", "--checkpoint", "C", "--tracks", "T", "--frame", "0", "--out", "o.png"],
    ],
)
def test_an_unavailable_device_is_one_line(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    from grouptron.cli import main

    assert main([*command, "--device", "cuda"]) == 2
    err = capsys.readouterr().err
    assert "CUDA is not available here" in err and "Traceback" not in err


@pytest.mark.parametrize("command", ["predict", "calibrate", "plot"])
def test_the_forecast_is_named_by_forecast_and_by_its_older_name(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """What predict, calibrate and plot draw is a forecast (``--forecast``); ``--mode`` names
    what evaluate scores, and is still read here as the older name, saying so on stderr and
    kept out of ``--help``."""
    base = [command, "--tracks", "t.txt", "--out", "o.csv"]
    for flag in ("--forecast", "--mode"):
        capsys.readouterr()
        mean = build_parser().parse_args([*base, flag, "mean"]).forecast
        assert mean == PointForecast.parse("mean")
        top3 = build_parser().parse_args([*base, flag, "ml-top3"]).forecast
        assert top3 == PointForecast.parse("ml-top3")
        told = "grouptron: --mode is now called --forecast" in capsys.readouterr().err
        assert told == (flag == "--mode")
    assert build_parser().parse_args(base).forecast is None  # the model's own
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--help"])
    shown = capsys.readouterr().out
    assert "--forecast" in shown  # neither in the usage nor as an option of its own:
    assert re.search(r"\[--mode|^\s+--mode", shown, re.MULTILINE) is None


@pytest.mark.parametrize("command", ["predict", "calibrate", "plot"])
def test_a_forecast_that_does_not_exist_is_refused_with_the_choices(command: str) -> None:
    base = [command, "--tracks", "t.txt", "--out", "o.csv", "--forecast"]
    for bad in ("ml-top0", "ml-top02", "ml-topx", "fast"):
        with pytest.raises(GrouptronError, match=r"ml-top10.* or ml-topK \(K = 2, 3, ...\)"):
            build_parser().parse_args([*base, bad])
    # ml of the one most probable latent value is the argmax latent, by its one name.
    assert build_parser().parse_args([*base, "ml-top1"]).forecast == PointForecast("ml", 1)
    assert eval_modes("ml-top3,ml") == ("ml-top3", "ml")
    with pytest.raises(GrouptronError, match="ml-topK, best-of-K or all"):
        eval_modes("ml-top1")
    assert eval_modes("best-of-5,best-of-20") == ("best-of-5", "best-of-20")
    with pytest.raises(GrouptronError, match="best-of-K"):
        eval_modes("best-of-05")
