"""Datasets of one's own: description files, training, fine-tuning and evaluating on them."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.config import DataConfig
from grouptron.data.datasets.custom import load_dataset_part, read_dataset, train_sample_weights
from grouptron.errors import GrouptronError
from grouptron.training.trainer import epoch_order


def walkers_file(path: Path, seed: int, people: int = 10, seconds: float = 18.0) -> Path:
    """People walking with small turns, sampled at 5 Hz, ``id,t,x,y`` in centimetres with
    Unix-like times: a layout and rate unlike ETH/UCY's."""
    rng = np.random.default_rng(seed)
    rows = ["id,t,x,y"]
    for ped in range(people):
        start = float(rng.uniform(0, seconds / 3))
        pos, vel = rng.uniform(-400, 400, size=2), rng.normal(0, 60, size=2) + np.array([80.0, 0.0])
        for t in np.arange(start, seconds, 0.2):
            vel = vel + rng.normal(0, 4, size=2)
            pos = pos + vel * 0.2
            rows.append(f"{ped},{1.7e9 + t:.3f},{pos[0]:.1f},{pos[1]:.1f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def write_dataset(folder: Path, name: str = "walkers") -> Path:
    for seed in range(4):
        walkers_file(folder / f"walk{seed}.csv", seed)
    description = folder / "walkers.toml"
    description.write_text(
        f'name = "{name}"\n'
        "[format]\n"
        'columns = "id,t,x,y"\n'
        'units = "cm"\n'
        "[parts]\n"
        'train = ["walk0.csv", "walk1.csv"]\n'
        'val = ["walk2.csv"]\n'
        'test = "walk3.csv"\n'
    )
    return description


def test_a_description_names_its_parts_and_their_format(tmp_path: Path) -> None:
    dataset = read_dataset(write_dataset(tmp_path))
    assert dataset.name == "walkers" and dataset.recording.units == "cm"
    assert [f.name for f in dataset.files("train")] == ["walk0.csv", "walk1.csv"]
    part = load_dataset_part(dataset, "test", DataConfig())
    assert len(part.samples) > 20  # resampled from 5 Hz to 0.4 s


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('name = "eth"\n[parts]\ntrain = ["walk0.csv"]\n', "is an ETH/UCY split"),
        ('name = "x"\nfiles = 3\n[parts]\ntrain = ["walk0.csv"]\n', "unknown keys files"),
        ('name = "x"\n[parts]\ntrain = ["missing.csv"]\n', "train files not found"),
        ('name = "x"\n[parts]\ntest2 = ["walk0.csv"]\n', "unknown part 'test2'"),
        ('name = "x"\n[format]\nfps = -1\n[parts]\ntrain = ["walk0.csv"]\n', "format: fps must be"),
        ("name = ", "cannot read the dataset description"),
    ],
)
def test_bad_descriptions_are_refused_in_one_line(tmp_path: Path, text: str, message: str) -> None:
    write_dataset(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(GrouptronError, match=message):
        read_dataset(bad)


@pytest.mark.slow
def test_fine_tuning_a_checkpoint_on_a_dataset_of_ones_own_runs_end_to_end(
    tiny_checkpoints: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    description = write_dataset(tmp_path)
    monkeypatch.setenv("GROUPTRON_CHECKPOINTS", str(tiny_checkpoints))
    out = tmp_path / "tuned"
    # As the docs write it: the shipped name alone brings model, architecture and derivatives.
    argv = ["train", "--dataset", str(description), "--init-from", "grouptron-eth-backward"]
    argv += ["--epochs", "1", "--lr", "0.0003"]
    argv += ["--out", str(out), "--quiet", "--precision", "fp32", "--set", "train.batch_size=32"]
    assert main(argv) == 0
    assert "training grouptron on walkers (backward derivatives)" in capsys.readouterr().out
    card = (out / "README.md").read_text()
    # The card's resume line works as written.
    resume = re.search(r"`(grouptron train --out <this folder> --resume --epochs N)`", card)
    assert resume is not None
    line = resume.group(1).replace("<this folder>", str(out)).replace("N", "2").split()[1:]
    assert main([*line, "--quiet"]) == 0
    assert "done: 2 epochs" in capsys.readouterr().out
    card = (out / "README.md").read_text()
    assert '`split = "walkers"`' in card and f"`dataset = {json.dumps(str(description))}`" in card
    assert "`train.learning_rate = 0.0003`" in card and "weights (fresh optimiser" in card
    stored = json.loads((out / "config.json").read_text())
    assert stored["group_encoder"]["group_dim"] == 4  # the source's, no ETH/UCY preset
    capsys.readouterr()
    tuned = str(out / "best.safetensors")
    assert (
        main(["evaluate", "--dataset", str(description), "--checkpoint", tuned, "--format", "json"])
        == 0
    )
    row, baseline = json.loads(capsys.readouterr().out)["results"]
    assert row["split"] == "walkers" and row["samples"] > 20 and row["fde"] > 0
    assert baseline["model"] == "constant-velocity" and baseline["samples"] == row["samples"]
    assert main(["evaluate", "--dataset", str(description), "--model", "constant-velocity"]) == 0
    capsys.readouterr()
    report = ["report", "--dataset", str(description), "--checkpoints", str(tmp_path), "--quiet"]
    assert main([*report, "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert [(r["model"], r["mode"]) for r in rows] == [
        ("constant-velocity", "ml"), ("grouptron", "ml"), ("grouptron", "best-of-20"),
    ]  # fmt: skip
    assert all(r["fde_ci"][0] <= r["fde"] <= r["fde_ci"][1] for r in rows)
    assert main([*report, "--checkpoints", str(tmp_path / "nowhere")]) == 2


def test_a_description_can_name_its_data_folder_by_an_environment_variable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A description that lives in the repository names data that lives elsewhere on each
    machine: ``${NAME}`` or ``${NAME:-default}`` (relative to the description)."""
    (tmp_path / "data").mkdir()
    write_dataset(tmp_path / "data")
    (tmp_path / "repo").mkdir()
    described = tmp_path / "repo" / "elsewhere.toml"
    described.write_text(
        'name = "elsewhere"\n[format]\ncolumns = "id,t,x,y"\nunits = "cm"\n[parts]\n'
        'test = ["${WALKERS_DIR:-../data}/walk3.csv"]\n'
    )
    monkeypatch.delenv("WALKERS_DIR", raising=False)
    assert read_dataset(described).parts["test"] == ((tmp_path / "data" / "walk3.csv").resolve(),)
    monkeypatch.setenv("WALKERS_DIR", str(tmp_path / "nowhere"))
    with pytest.raises(GrouptronError, match=r"test files not found: .*\(set \$WALKERS_DIR"):
        read_dataset(described)
    described.write_text(described.read_text().replace(":-../data", ""))
    monkeypatch.delenv("WALKERS_DIR")
    with pytest.raises(GrouptronError, match=r"names \$WALKERS_DIR, which is not set"):
        read_dataset(described)


def _sourced(folder: Path, shares: str = "") -> Path:
    write_dataset(folder)
    described = folder / "sourced.toml"
    described.write_text(
        'name = "sourced"\n[format]\ncolumns = "id,t,x,y"\nunits = "cm"\n'
        '[parts.train]\nbig = ["walk0.csv", "walk1.csv", "walk2.csv"]\nsmall = "walk3.csv"\n'
        + shares
    )
    return described


def test_named_train_sources_get_their_share_of_each_epoch(tmp_path: Path) -> None:
    """Three files of one source and one of another: drawn by the weights, each source makes
    half of an epoch, however many samples it holds."""
    dataset = read_dataset(_sourced(tmp_path))
    assert list(dataset.sources) == ["big", "small"] and dataset.shares == {
        "big": 0.5,
        "small": 0.5,
    }
    part = load_dataset_part(dataset, "train", DataConfig(), use_cache=False)
    # The samples' scene is their file: walk3.csv's samples are scene 3.
    assert sorted(set(part.samples.scene_index.tolist())) == [0, 1, 2, 3]
    weights = train_sample_weights(dataset, part.samples)
    assert weights is not None
    small = part.samples.scene_index == 3
    assert small.sum() * 2 < (~small).sum()  # the small source really is smaller
    assert weights[small].sum() == pytest.approx(0.5) and weights.sum() == pytest.approx(1.0)
    order = epoch_order(np.random.default_rng(0), len(weights), weights, 4000)
    assert len(order) == 4000 and abs(small[order].mean() - 0.5) < 0.05
    uneven = read_dataset(_sourced(tmp_path, "[shares]\nbig = 3\nsmall = 1\n"))
    assert uneven.shares == {"big": 0.75, "small": 0.25}
    # Without named sources an epoch is one shuffled pass, as always.
    plain = read_dataset(write_dataset(tmp_path))
    assert plain.shares == {} and train_sample_weights(plain, part.samples) is None
    assert sorted(epoch_order(np.random.default_rng(0), 7, None, 0).tolist()) == list(range(7))


@pytest.mark.parametrize(
    ("shares", "message"),
    [
        ("[shares]\nbig = 1\n", "must name exactly the train sources"),
        ("[shares]\nbig = 1\nsmall = -1\n", "shares are numbers >= 0"),
        ("[shares]\nbig = 0\nsmall = 0\n", "not all 0"),
    ],
)
def test_bad_shares_are_refused_in_one_line(tmp_path: Path, shares: str, message: str) -> None:
    with pytest.raises(GrouptronError, match=message):
        read_dataset(_sourced(tmp_path, shares))
