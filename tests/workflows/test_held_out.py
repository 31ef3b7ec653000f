"""No score of a checkpoint on data it trained or validated on: another split's test set is
refused in one line, or scored only when asked and then marked not held out everywhere."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from grouptron.cli import main
from grouptron.constants import CONSTANT_VELOCITY, SPLITS
from grouptron.data.datasets.download import file_sha256
from grouptron.errors import GrouptronError
from grouptron.evaluation.recordings import benchmark_seen
from grouptron.evaluation.results import results_table
from grouptron.model.checkpoint import load_checkpoint, load_trained_model, save_checkpoint
from grouptron.reporting.report import ReportCheckpoint, ReportSettings, score_checkpoint
from grouptron.workflows.adapt import ADAPTATION
from grouptron.workflows.evaluate import Benchmark, EvaluationOptions, Tracks, evaluate


@pytest.fixture(scope="module")
def five_splits(synthetic_data_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The synthetic eth split copied under every split's name (leave one location out's
    folders, in shape)."""
    root = tmp_path_factory.mktemp("five")
    for split in SPLITS:
        shutil.copytree(synthetic_data_dir / "eth", root / split)
    return root


def _checkpoint(tiny_checkpoints: Path) -> str:
    return str(tiny_checkpoints / "trajectron++-eth-central/best.safetensors")


def test_every_other_split_is_seen_by_a_split_checkpoint(
    tiny_checkpoints: Path, five_splits: Path
) -> None:
    _, experiment = load_trained_model(Path(_checkpoint(tiny_checkpoints)))
    assert experiment.split == "eth"
    assert benchmark_seen(experiment, five_splits, "eth") is None
    for split in SPLITS[1:]:
        why = benchmark_seen(experiment, five_splits, split)
        assert why is not None and f"{split}'s test location" in why


def test_another_splits_test_set_is_refused_in_one_line(
    tiny_checkpoints: Path, five_splits: Path
) -> None:
    checkpoint = _checkpoint(tiny_checkpoints)
    for splits in (("hotel",), ("eth", "univ"), SPLITS):
        source = Benchmark(splits=splits, data_dir=five_splits)
        with pytest.raises(GrouptronError, match=r"not held out from .*--include-seen") as caught:
            evaluate(source, checkpoint, ("ml",))
        assert "\n" not in str(caught.value)
    own = evaluate(Benchmark(data_dir=five_splits), checkpoint, ("ml",))
    assert {r.split for r in own} == {"eth"} and all(r.held_out for r in own)


def test_with_include_seen_every_seen_row_is_marked_in_table_and_json(
    tiny_checkpoints: Path, five_splits: Path
) -> None:
    checkpoint = _checkpoint(tiny_checkpoints)
    options = EvaluationOptions(include_seen=True)
    rows = evaluate(Benchmark(splits=SPLITS, data_dir=five_splits), checkpoint, ("ml",), options)
    model = [r for r in rows if r.model != CONSTANT_VELOCITY]
    assert {r.split: r.held_out for r in model} == {
        "eth": True,
        "hotel": False,
        "univ": False,
        "zara1": False,
        "zara2": False,
        "mean": False,  # a mean over seen splits is not held out either
    }
    assert all(r.held_out for r in rows if r.model == CONSTANT_VELOCITY)
    table = results_table(rows).splitlines()
    marked = [line for line in table if "not held out" in line]
    assert len(marked) == 5 and not any(line.startswith("eth ") for line in marked)
    assert all(r.to_dict().get("held_out", True) is r.held_out for r in rows)
    assert all(("held_out" in r.to_dict()) is not r.held_out for r in rows)  # false: named


def test_the_command_refuses_or_marks(
    tiny_checkpoints: Path, five_splits: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--checkpoint", _checkpoint(tiny_checkpoints), "--mode", "ml"]
    argv += ["--split", "all", "--data-dir", str(five_splits), "--quiet"]
    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "hotel's test set" in error
    assert main([*argv, "--include-seen", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    seen = {r["split"]: r.get("held_out", True) for r in rows if r["model"] != CONSTANT_VELOCITY}
    assert seen == {s: s == "eth" for s in (*SPLITS, "mean")}


def test_track_files_seen_in_training_are_marked(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    adapted = tmp_path / "adapted"  # a checkpoint whose run adapted on the first file
    shutil.copytree(tiny_checkpoints / "trajectron++-eth-central", adapted)
    seen, unseen = sorted((synthetic_data_dir / "eth" / "train").glob("*.txt"))[:2]
    record = {"files": [{"sha256": file_sha256(seen), "adapted_until_s": 10.0}]}
    (adapted / ADAPTATION).write_text(json.dumps(record))
    rows = evaluate(Tracks((seen, unseen)), str(adapted / "best.safetensors"), ("ml",))
    by_split = {(r.split, r.model): r.held_out for r in rows}
    assert by_split[(seen.name, "trajectron++")] is False
    assert by_split[("all files", "trajectron++")] is False
    assert by_split[(unseen.name, "trajectron++")] is True
    assert all(r.held_out for r in rows if r.model == CONSTANT_VELOCITY)


def test_the_report_scores_each_checkpoint_on_its_own_split_only(
    tiny_checkpoints: Path, five_splits: Path
) -> None:
    path = Path(_checkpoint(tiny_checkpoints))
    settings = ReportSettings(modes=("ml",))
    run = score_checkpoint(
        ReportCheckpoint("trajectron++", "eth", "central", path), five_splits, settings
    )
    assert {r.split for r in run.rows} == {"eth"} and all(r.held_out for r in run.rows)
    with pytest.raises(GrouptronError, match="expected trajectron\\+\\+ on hotel"):
        score_checkpoint(
            ReportCheckpoint("trajectron++", "hotel", "central", path), five_splits, settings
        )


def test_a_dataset_model_whose_description_is_not_here_is_not_taken_as_held_out(
    tiny_checkpoints: Path, five_splits: Path, tmp_path: Path
) -> None:
    stored = load_checkpoint(tiny_checkpoints / "trajectron++-eth-central" / "best.safetensors")
    elsewhere = dataclasses.replace(
        stored.config, split="site", dataset=str(tmp_path / "gone.toml")
    )
    path = tmp_path / "site-model" / "best.safetensors"
    save_checkpoint(path, dataclasses.replace(stored, config=elsewhere))
    with pytest.raises(GrouptronError, match="cannot be read: what it saw is unknown"):
        evaluate(Benchmark(splits=("eth",), data_dir=five_splits), str(path), ("ml",))
    options = EvaluationOptions(include_seen=True)
    rows = evaluate(Benchmark(splits=("eth",), data_dir=five_splits), str(path), ("ml",), options)
    assert [r.held_out for r in rows] == [False, True]  # the model's row, constant velocity's
