"""The node on a real rclpy graph (an isolated domain on this machine): forecasts equal to
``predict`` on the same tracks, markers and diagnostics on every input, malformed inputs
survived, a moving frame refused."""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.inference.learning import LearningOptions
from grouptron.inference.predictor import Predictor
from grouptron.ros2.messages import Tracked
from grouptron.ros2.node import NodeOptions, make_node
from grouptron.training.fine_tune import FineTune
from tests.conftest import synthetic_recording
from tests.golden.compute import synthetic_tracks
from tests.helpers.ros2_graph import Probe

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.usefixtures("graph")  # rclpy on a domain of its own (conftest)


def _people(tracks: np.ndarray, frame: int) -> Tracked:
    now = tracks[tracks[:, 0] == frame]
    return Tracked(frame / 25.0 + 100.0, "map", [str(int(i)) for i in now[:, 1]], now[:, 2:4])


def test_the_node_forecasts_as_predict_does_and_says_so(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    forecaster = make_node(Predictor.from_checkpoint(checkpoint), NodeOptions(name="gt_a"))
    probe = Probe()
    tracks = synthetic_tracks()
    for frame in np.unique(tracks[:, 0]):
        assert probe.send(_people(tracks, int(frame)), forecaster), frame
    last = probe.got["forecasts"][-1]
    assert len(last.points) == 12 and last.header.frame_id == "map"
    assert last.points[0].time_from_start.nanosec == 400_000_000
    path = tmp_path / "tracks.txt"
    np.savetxt(path, tracks, fmt="%.6f")
    out = tmp_path / "f.csv"
    assert main(["predict", "--checkpoint", str(checkpoint), "--tracks", str(path), "--out",
                 str(out), "--quiet"]) == 0  # fmt: skip
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    final = rows[rows[:, 0] == tracks[:, 0].max()]
    assert len(final)
    for person in np.unique(final[:, 1]):
        i = last.joint_names.index(str(int(person)))
        sent = np.array([[p.transforms[i].translation.x, p.transforms[i].translation.y]
                         for p in last.points])  # fmt: skip
        np.testing.assert_allclose(sent, final[final[:, 1] == person][:, 3:5], atol=1e-3)
    assert any(m.ns == "region" for m in probe.got["markers"][-1].markers)
    values = {kv.key: kv.value for kv in probe.got["diagnostics"][-1].status[0].values}
    assert values["forecast inputs"] == str(len(np.unique(tracks[:, 0])))
    # The groups on the graph are Forecast.group of the same update, fed the same messages.
    session = Predictor.from_checkpoint(checkpoint).stream()
    for frame in np.unique(tracks[:, 0]):
        people = _people(tracks, int(frame))
        forecast = session.update(people.time_s, people.ids, people.xy)
    assert forecast.group is not None
    expected = {
        frozenset(str(i) for i in forecast.ids[forecast.group == g])
        for g in np.unique(forecast.group)
        if (forecast.group == g).sum() >= 2
    }
    sent = {frozenset(m.text.split(",")) for m in probe.got["groups"][-1].markers[1:]}
    assert expected and sent == expected
    assert probe.got["groups"][-1].markers[0].header.stamp == last.header.stamp
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_malformed_inputs_are_survived_and_a_moving_frame_refused(tiny_checkpoints: Path) -> None:
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    forecaster = make_node(Predictor.from_checkpoint(checkpoint), NodeOptions(name="gt_b"))
    probe = Probe()
    good = Tracked(100.0, "map", ["1", "2"], np.array([[0.0, 0.0], [1.0, 1.0]]))
    assert probe.send(good, forecaster)
    bad = [
        Tracked(100.4, "map", ["1", "2"], np.array([[np.nan, 0.0], [1.0, 1.0]])),
        Tracked(100.8, "base_link", ["1", "2"], np.array([[0.0, 0.0], [1.0, 1.0]])),
    ]
    for message in bad:
        assert probe.send(message, forecaster)  # no forecast: a counted refusal
    assert probe.send(Tracked(101.2, "map", ["1", "2"], np.array([[0.5, 0], [1, 1.5]])), forecaster)
    values = {kv.key: kv.value for kv in probe.got["diagnostics"][-1].status[0].values}
    assert values["malformed inputs"] == "2" and values["forecast inputs"] == "2"
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_a_node_that_learns_says_what_its_rounds_did(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    rounds = LearningOptions(
        round_s=2.0,
        budget=FineTune(steps=5),
        min_train=10,
        min_holdout=5,
        min_holdout_steps=2,
        background=False,
    )
    predictor = Predictor.from_checkpoint(checkpoint)
    forecaster = make_node(predictor, NodeOptions(name="gt_c"), learn=rounds)
    probe = Probe()
    tracks = np.loadtxt(synthetic_recording(tmp_path / "site.txt", 11, 14, 90))
    for frame in np.unique(tracks[:, 0]):
        assert probe.send(_people(tracks, int(frame)), forecaster), frame
    values = {kv.key: kv.value for kv in probe.got["diagnostics"][-1].status[0].values}
    status = forecaster.session.learning
    assert status is not None and status.rounds >= 1
    assert values["learning"] == status.line()
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_the_command_runs_for_its_seconds_and_keeps_its_site(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    """``grouptron ros2`` in a process of its own: it spins, stops after ``--seconds`` and
    keeps what ``--learn`` learnt (nothing in a second without people) in ``--save-site``."""
    import subprocess
    import sys

    env = {**os.environ, "ROS_DOMAIN_ID": str(random.randint(10, 99)), "ROS_LOCALHOST_ONLY": "1"}
    checkpoint = tiny_checkpoints / "grouptron-eth-backward"
    argv = ["ros2", "--checkpoint", str(checkpoint), "--seconds", "1", "--learn"]
    argv += ["--save-site", str(tmp_path / "site")]
    command = [sys.executable, "-m", "grouptron", *argv]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "site" / "site.json").is_file()
    assert "kept the site's weights" in done.stdout


def test_ros_parameters_after_ros_args_override_the_flags(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    """``-p learn:=true`` turns learning on without ``--learn`` (its site is kept), and
    ``-p learn:=false`` off despite it (nothing to keep: refused before the node runs)."""
    import subprocess
    import sys

    env = {**os.environ, "ROS_DOMAIN_ID": str(random.randint(10, 99)), "ROS_LOCALHOST_ONLY": "1"}
    checkpoint = tiny_checkpoints / "grouptron-eth-backward"
    argv = [sys.executable, "-m", "grouptron", "ros2", "--checkpoint", str(checkpoint)]
    argv += ["--seconds", "1", "--save-site", str(tmp_path / "site")]
    done = subprocess.run(
        [*argv, "--ros-args", "-p", "learn:=true"], capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "site" / "site.json").is_file()
    done = subprocess.run(
        [*argv, "--learn", "--ros-args", "-p", "learn:=false"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 2 and "add --learn" in done.stderr
