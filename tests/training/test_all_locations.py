"""Training on all five locations: every train and val part once, no validation, the last
epoch kept, and no benchmark score pretending to be held out."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from grouptron.cli import main
from grouptron.constants import ALL_LOCATIONS, SPLITS
from grouptron.data.datasets.locate import split_files
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import load_checkpoint
from tests.conftest import synthetic_recording
from tests.helpers.models import TINY_MODEL


@pytest.fixture(scope="module")
def five_locations(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An ETH/UCY-shaped folder: location i's train and val parts sit in the folders of the
    four other splits, its whole recording in its own split's test folder."""
    root = tmp_path_factory.mktemp("five")
    for i, split in enumerate(SPLITS):
        synthetic_recording(root / split / "test" / f"place{i}.txt", 10 + i)
        for j in range(len(SPLITS)):
            if j != i:
                for part, seed in (("train", 20 + j), ("val", 30 + j)):
                    synthetic_recording(root / split / part / f"place{j}_{part}.txt", seed)
    return root


def test_all_locations_reads_every_train_and_val_part_once(five_locations: Path) -> None:
    files = split_files(five_locations, ALL_LOCATIONS, "train")
    assert [f.name for f in files] == sorted(
        f"place{j}_{part}.txt" for j in range(5) for part in ("train", "val")
    )
    for part in ("val", "test"):
        with pytest.raises(GrouptronError, match=f"no {part} part"):
            split_files(five_locations, ALL_LOCATIONS, part)


@pytest.mark.slow
def test_an_all_locations_run_keeps_its_last_epoch_and_refuses_benchmark_scores(
    five_locations: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.json"
    config.write_text(json.dumps({"model": TINY_MODEL, "train": {"batch_size": 64}}))
    out = tmp_path / "everywhere"
    argv = ["train", "--split", ALL_LOCATIONS, "--model", "grouptron", "--epochs", "2"]
    argv += ["--derivatives", "backward", "--config", str(config), "--out", str(out)]
    assert main([*argv, "--data-dir", str(five_locations), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert " 0 validation samples" in printed and "the last epoch" in printed
    best, last = (
        load_checkpoint(out / "best.safetensors"),
        load_checkpoint(out / "last.safetensors"),
    )
    assert best.epoch == last.epoch == 2
    for name, weights in best.model_state.items():
        torch.testing.assert_close(weights, last.model_state[name])
    selection = json.loads((out / "selection.json").read_text())
    assert selection["selected_epoch"] == 2 and selection["validation_samples"] == 0
    card = (out / "README.md").read_text()
    assert "nothing held out" in card and "the last: no validation data" in card

    evaluate = ["evaluate", "--checkpoint", str(out / "best.safetensors")]
    assert main([*evaluate, "--data-dir", str(five_locations)]) != 0
    assert "--tracks" in capsys.readouterr().err
    # Recordings of one's own are what such a model is scored on.
    tracks = synthetic_recording(tmp_path / "mine.txt", 99, pedestrians=6, steps=30)
    assert main([*evaluate, "--tracks", str(tracks), "--format", "json"]) == 0
    assert json.loads(capsys.readouterr().out)["results"]
