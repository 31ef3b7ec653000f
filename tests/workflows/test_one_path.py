"""One reading path and one forecasting path: a bag reads in every command as its tracks do in
a text file, and ``predict``, a live session fed frame by frame and ``evaluate --tracks`` make
the same forecasts of every person with a full history."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

pytest.importorskip("mcap_ros2")

from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from grouptron.data.formats.track_files import TrackSource, load_tracks
from grouptron.inference.predictor import Predictor
from grouptron.workflows.adapt import AdaptRequest, adapt
from grouptron.workflows.evaluate import Tracks, evaluate
from tests.helpers.ros import START_S, write_people_bag


@pytest.fixture(scope="module")
def recording(synthetic_data_dir: Path) -> np.ndarray:
    """(R, 4) frame, id, x, y rows of a synthetic eth test file (25 fps frames)."""
    return np.loadtxt(split_files(synthetic_data_dir, "eth", "test")[0])


@pytest.fixture(scope="module")
def bag_and_text(recording: np.ndarray, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The recording as a People bag and as a CSV in Unix seconds."""
    folder = tmp_path_factory.mktemp("one-path")
    bag, text = folder / "run.mcap", folder / "run.csv"
    write_people_bag(bag, recording)
    seconds = START_S + recording[:, 0] / 25.0
    np.savetxt(text, np.column_stack([seconds, recording[:, 1:]]), fmt="%.6f", delimiter=",")
    return [bag, text]


def _evaluated(
    capsys: pytest.CaptureFixture[str], checkpoint: Path, tracks: list[str]
) -> list[dict[str, object]]:
    argv = ["evaluate", "--checkpoint", str(checkpoint), "--tracks", *tracks, "--quiet"]
    capsys.readouterr()
    assert main([*argv, "--format", "json"]) == 0
    rows: list[dict[str, object]] = json.loads(capsys.readouterr().out)["results"]
    return [{k: v for k, v in row.items() if k != "split"} for row in rows]


def test_evaluate_reads_a_bag_as_the_same_tracks_in_a_text_file(
    tiny_checkpoints: Path, bag_and_text: list[Path], capsys: pytest.CaptureFixture[str]
) -> None:
    bag, text = bag_and_text
    checkpoint = tiny_checkpoints / "grouptron-eth-backward"
    from_bag = _evaluated(capsys, checkpoint, [str(bag), "--topic", "/people"])
    from_text = _evaluated(capsys, checkpoint, [str(text), "--columns", "t,id,x,y"])
    assert len(from_bag) >= 2 and from_bag == from_text


def test_adapt_and_load_tracks_read_a_bag_as_its_text_file(
    tiny_checkpoints: Path, bag_and_text: list[Path], tmp_path: Path
) -> None:
    bag, text = bag_and_text
    layouts = {bag: TrackSource("", topic="/people"), text: TrackSource("", columns="t,id,x,y")}
    np.testing.assert_allclose(
        load_tracks(layouts[bag].of(bag)), load_tracks(layouts[text].of(text)), atol=1e-5
    )
    weights = []
    for path, layout in layouts.items():
        request = AdaptRequest(
            files=(path,), layout=layout, minutes=0.25, steps=2,
            checkpoint=str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"),
            out=str(tmp_path / path.suffix.strip(".")), threads=1,
        )  # fmt: skip
        done = adapt(request)
        assert done.samples > 10
        weights.append(load_file(str(done.out / "best.safetensors")))
    for name, tensor in weights[0].items():
        torch.testing.assert_close(tensor, weights[1][name], atol=1e-5, rtol=0)


def test_predict_a_live_session_and_evaluate_make_the_same_forecasts(
    tiny_checkpoints: Path, recording: np.ndarray, tmp_path: Path
) -> None:
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    tracks = tmp_path / "tracks.txt"
    np.savetxt(tracks, recording, fmt="%.4f", delimiter="\t")
    out = tmp_path / "forecasts.csv"
    assert main(["predict", "--checkpoint", str(checkpoint), "--tracks", str(tracks),
                 "--out", str(out), "--forecast", "ml", "--quiet"]) == 0  # fmt: skip
    written = np.loadtxt(out, delimiter=",", skiprows=1)  # frame, id, step, x, y
    predicted = {
        (int(f), int(i)): written[(written[:, 0] == f) & (written[:, 1] == i)][:, 3:5]
        for f, i in {(f, i) for f, i in written[:, :2]}
    }
    # A session fed one frame at a time forecasts everyone with 2 points; those with a full
    # history are the ones predict forecasts, and must be the same forecasts.
    session = Predictor.from_checkpoint(checkpoint, forecast="ml").stream()
    compared = 0
    for frame in np.unique(recording[:, 0]):
        now = recording[recording[:, 0] == frame]
        live = session.update(int(frame), now[:, 1], now[:, 2:4])
        for i, person in enumerate(live.ids):
            key = (int(frame), int(person))
            if key in predicted:
                np.testing.assert_allclose(live.point[i], predicted[key], atol=1e-3)
                compared += 1
    assert compared == len(predicted) > 20
    # evaluate scores the forecasts of everyone with a full future: the same ones.
    truth = {(int(f), int(i)): (x, y) for f, i, x, y in recording}
    errors = []
    for (frame, person), path in predicted.items():
        future = [truth.get((frame + 10 * k, person)) for k in range(1, 13)]
        if all(p is not None for p in future):
            errors.append(np.linalg.norm(path - np.array(future), axis=1))
    ade, fde = np.mean([e.mean() for e in errors]), np.mean([e[-1] for e in errors])
    rows = evaluate(Tracks((tracks,)), checkpoint, ("ml",))
    (row,) = [r for r in rows if r.model == "grouptron" and r.split == "all files"]
    assert row.samples == len(errors)
    assert row.ade == pytest.approx(ade, abs=1e-3) and row.fde == pytest.approx(fde, abs=1e-3)


def test_a_bags_names_are_kept_in_the_csv(
    tiny_checkpoints: Path, recording: np.ndarray, tmp_path: Path
) -> None:
    bag, out = tmp_path / "named.mcap", tmp_path / "named.csv"
    write_people_bag(bag, recording, prefix="walker-")
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    assert main(["predict", "--checkpoint", checkpoint, "--tracks", str(bag), "--topic",
                 "/people", "--out", str(out), "--quiet"]) == 0  # fmt: skip
    lines = out.read_text().splitlines()
    assert lines[0].startswith("frame,id,step") and len(lines) > 100
    names = {line.split(",")[1] for line in lines[1:]}
    assert names <= {f"walker-{int(i)}" for i in recording[:, 1]} and len(names) > 3


def test_a_bag_of_people_seen_from_a_moving_robot_with_its_odometry_predicts_as_in_odom(
    recording: np.ndarray,
    tiny_checkpoints: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The recording in ``odom``, and the same people in ``base_link`` of a robot driving a
    circle with its odometry on ``/odom``: ``--odom-topic`` gives the same forecasts."""

    def robot(t_s: float) -> np.ndarray:
        turn = 0.2 * (t_s - START_S)  # 1 m/s on a 5 m circle
        return np.array([5.0 * np.sin(turn), 5.0 - 5.0 * np.cos(turn), turn])

    fixed, moving = tmp_path / "odom.mcap", tmp_path / "base.mcap"
    write_people_bag(fixed, recording, frame_id="odom")
    write_people_bag(moving, recording, robot=robot)
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    out = {}
    for name, bag, extra in (("fixed", fixed, []), ("moving", moving, ["--odom-topic", "/odom"])):
        out[name] = tmp_path / f"{name}.csv"
        argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(bag), "--topic", "/people"]
        assert main([*argv, *extra, "--out", str(out[name]), "--quiet"]) == 0
    expected = np.loadtxt(out["fixed"], delimiter=",", skiprows=1)
    got = np.loadtxt(out["moving"], delimiter=",", skiprows=1)
    assert len(expected) > 100
    np.testing.assert_allclose(got, expected, atol=1e-6)
    refused = ["predict", "--checkpoint", checkpoint, "--tracks", str(moving), "--topic"]
    refused += ["/people", "--out", str(tmp_path / "x.csv"), "--quiet"]
    assert main(refused) == 2  # without odometry: base_link moves with the robot
    assert "moves with the robot" in capsys.readouterr().err
