"""A model written outside the package (docs/models.md's example) trained, evaluated and used
by the same commands and API as the shipped ones, with no change to the package."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.inference.predictor import Predictor
from grouptron.model.checkpoint import load_checkpoint
from grouptron.workflows.train import TrainRequest, make_experiment
from tests.conftest import REPO

EXAMPLE = REPO / "examples/models/lstm_forecaster.py"
MODEL = "lstm_forecaster:LSTMForecaster"


@pytest.fixture
def outside_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder outside the repository holding the example model, as the working directory
    (the import path and module cache restored afterwards)."""
    shutil.copy(EXAMPLE, tmp_path / EXAMPLE.name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.delitem(sys.modules, "lstm_forecaster", raising=False)
    yield tmp_path
    sys.modules.pop("lstm_forecaster", None)


@pytest.mark.slow
def test_a_model_written_elsewhere_trains_evaluates_and_forecasts(
    outside_folder: Path, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = ["--data-dir", str(synthetic_data_dir)]
    train = ["train", "--model", MODEL, "--split", "eth", "--epochs", "1", "--out", "run"]
    settings = ["--set", "model_settings.hidden=8", "--batch-size", "64", "--threads", "1"]
    assert main([*train, *settings, *data]) == 0
    trained = capsys.readouterr().out
    assert "epoch 1/1: loss" in trained and "best.safetensors is epoch 1" in trained
    stored = load_checkpoint(outside_folder / "run/best.safetensors").config
    assert (stored.model_name, stored.model_settings) == (MODEL, {"hidden": 8})
    assert not stored.train.bf16  # auto leaves an outside model's arithmetic to it

    evaluate = ["evaluate", "--checkpoint", "run/best.safetensors", "--split", "eth"]
    assert main([*evaluate, *data, "--format", "json", "--quiet"]) == 0
    ours, baseline = json.loads(capsys.readouterr().out)["results"]
    assert (ours["model"], ours["mode"]) == (MODEL, "ml")
    assert ours["samples"] == baseline["samples"] > 0 and np.isfinite(ours["fde"])

    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    predict = ["predict", "--checkpoint", "run", "--tracks", tracks, "--quiet"]
    assert main([*predict, "--out", "f.csv", "--regions", "0.9"]) == 0
    assert f"({MODEL}, backward derivatives, ml)" in capsys.readouterr().out
    rows = np.loadtxt("f.csv", delimiter=",", skiprows=1)
    assert rows.shape[1] == 9 and (rows[:, 6] > 0).all()  # its own Gaussians' regions

    predictor = Predictor.from_checkpoint("run/best.safetensors")
    forecast = predictor.predict(np.loadtxt(tracks)[:200], num_samples=3)
    assert forecast.point.shape[1:] == (12, 2) and forecast.samples is not None
    assert forecast.samples.shape[1:] == (3, 12, 2)
    assert np.isfinite(forecast.regions(0.9).major_m).all()


def test_names_that_name_no_model_fail_before_any_work(outside_folder: Path) -> None:
    with pytest.raises(GrouptronError, match=r"unknown model 'my-transformer'.*package.module"):
        make_experiment(TrainRequest(split="eth", model="my-transformer"))
    with pytest.raises(GrouptronError, match=r"cannot import it"):
        make_experiment(TrainRequest(split="eth", model="no_such_module:Model"))
    with pytest.raises(GrouptronError, match=r"not a grouptron.model.forecaster.Forecaster"):
        make_experiment(TrainRequest(split="eth", model="lstm_forecaster:Settings"))
    (outside_folder / "broken.py").write_text("import not_installed_anywhere\n")
    with pytest.raises(GrouptronError, match=r"importing it failed .*not_installed_anywhere"):
        make_experiment(TrainRequest(split="eth", model="broken:Model"))
    bad = TrainRequest(split="eth", model=MODEL, settings=("model_settings.width=3",))
    config = make_experiment(bad, choose_precision=False)  # the settings are the model's
    from grouptron.model.factory import build_model

    with pytest.raises(GrouptronError, match=r"could not be built from its settings.*width"):
        build_model(config)


def test_a_packages_entry_point_names_its_model(
    outside_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from importlib.metadata import EntryPoint

    from grouptron.model import forecaster

    point = EntryPoint(name="lstm", value=MODEL, group=forecaster.ENTRY_POINT_GROUP)
    monkeypatch.setattr(forecaster, "entry_points", lambda group: [point])
    sys.path.insert(0, str(outside_folder))  # as an installed package would be
    assert forecaster.outside_forecaster("lstm").__name__ == "LSTMForecaster"
    with pytest.raises(GrouptronError, match=r"choose from trajectron\+\+, .*, lstm"):
        forecaster.outside_forecaster("lstn")
