"""ROS 2 bags in (people_msgs/msg/People), Foxglove scene messages out."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mcap_ros2")

from mcap.reader import make_reader

from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from tests.helpers.ros import START_S, write_people_bag


@pytest.fixture(scope="module")
def recording(synthetic_data_dir: Path) -> np.ndarray:
    return np.loadtxt(split_files(synthetic_data_dir, "eth", "test")[0])


def test_a_people_bag_gives_the_forecasts_of_the_same_tracks_in_a_csv(
    tiny_checkpoints: Path, recording: np.ndarray, tmp_path: Path
) -> None:
    bag, csv = tmp_path / "run.mcap", tmp_path / "run.csv"
    write_people_bag(bag, recording)
    seconds = START_S + recording[:, 0] / 25.0
    np.savetxt(csv, np.column_stack([seconds, recording[:, 1:]]), fmt="%.6f", delimiter=",")
    checkpoint = ["--checkpoint", str(tiny_checkpoints / "grouptron-eth-backward"), "--quiet"]
    from_bag, from_csv = tmp_path / "bag.csv", tmp_path / "csv.csv"
    assert main(["predict", "--tracks", str(bag), "--topic", "/people",
                 "--out", str(from_bag), *checkpoint]) == 0  # fmt: skip
    assert main(["predict", "--tracks", str(csv), "--columns", "t,id,x,y",
                 "--out", str(from_csv), *checkpoint]) == 0  # fmt: skip
    a, b = (np.loadtxt(p, delimiter=",", skiprows=1) for p in (from_bag, from_csv))
    assert len(a) > 100
    np.testing.assert_allclose(a, b, atol=1e-4)


def test_forecasts_play_back_as_scene_messages(
    tiny_checkpoints: Path, recording: np.ndarray, tmp_path: Path
) -> None:
    bag, out, csv = tmp_path / "run.mcap", tmp_path / "forecasts.mcap", tmp_path / "f.csv"
    write_people_bag(bag, recording)
    argv = ["predict", "--tracks", str(bag), "--topic", "/people", "--quiet",
            "--checkpoint", str(tiny_checkpoints / "grouptron-eth-backward")]  # fmt: skip
    assert main([*argv, "--out", str(out), "--regions", "0.9"]) == 0
    assert main([*argv, "--out", str(csv)]) == 0
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    per_frame = {int(f): len(np.unique(rows[rows[:, 0] == f, 1])) for f in np.unique(rows[:, 0])}
    with out.open("rb") as handle:
        messages = list(make_reader(handle).iter_messages(topics=["/grouptron/forecasts"]))
    assert len(messages) == len(per_frame)
    for (schema, _, message), count in zip(messages, per_frame.values(), strict=True):
        assert schema.name == "foxglove.SceneUpdate"
        update = json.loads(message.data)
        assert len(update["entities"]) == count  # one entity per forecast
        entity = update["entities"][0]
        assert entity["frame_id"] == "map" and len(entity["lines"][0]["points"]) == 13
        assert len(entity["cylinders"]) == 12  # one region per step
        assert message.log_time >= START_S * 1e9  # on the bag's clock


def test_tracks_in_a_robot_frame_or_a_missing_topic_are_refused(
    tiny_checkpoints: Path,
    recording: np.ndarray,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    bag = tmp_path / "run.mcap"
    write_people_bag(bag, recording, frame_id="base_link")
    argv = ["predict", "--tracks", str(bag), "--out", str(tmp_path / "f.csv"), "--quiet",
            "--checkpoint", str(tiny_checkpoints / "grouptron-eth-backward")]  # fmt: skip
    assert main([*argv, "--topic", "/people"]) == 2
    assert "moves with the robot" in capsys.readouterr().err
    assert main([*argv, "--topic", "/people", "--fixed-frame", "base_link"]) == 0
    assert main([*argv, "--topic", "/tracks"]) == 2
    assert "the bag has /people (people_msgs/msg/People)" in capsys.readouterr().err
    assert main(argv) == 2
    assert "--topic" in capsys.readouterr().err
