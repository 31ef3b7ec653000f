"""The node on a real rclpy graph survives what a robot's tracker and clock get wrong, says
so on ``/diagnostics``, keeps its state across restarts, stops cleanly on a signal, and sends
markers a robot's network carries."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from grouptron.inference.predictor import Predictor
from grouptron.ros2.health import ERROR, OK, STALE
from grouptron.ros2.messages import Tracked
from grouptron.ros2.node import NodeOptions, make_node
from tests.helpers.ros2_graph import Probe

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.usefixtures("graph")  # rclpy on a domain of its own (conftest)

START_S = 1_700_000_000.0


def _walkers(t_s: float, frame: str = "map") -> Tracked:
    x = 1.3 * (t_s - START_S) % 50.0
    return Tracked(t_s, frame, ["1", "2"], np.array([[x, 0.0], [x, 3.0]]))


def _forecast_people(probe: Probe) -> int:
    return len(probe.got["forecasts"][-1].joint_names) if probe.got["forecasts"] else 0


def test_stamps_that_jump_forward_and_back_are_survived() -> None:
    forecaster = make_node(Predictor.from_checkpoint(), NodeOptions(name="gt_clock"))
    probe = Probe()
    times = [START_S + 0.4 * k for k in range(10)]
    for t in times:
        assert probe.send(_walkers(t), forecaster)
    assert _forecast_people(probe) == 2
    assert probe.send(_walkers(times[-1] + 60.0), forecaster)  # a minute ahead
    people = []
    for k in range(1, 4):  # the tracker's own stamps again
        before = len(probe.got["forecasts"])
        assert probe.send(_walkers(times[-1] + 0.4 * k), forecaster)
        people.append(_forecast_people(probe) if len(probe.got["forecasts"]) > before else 0)
    assert people[1:] == [2, 2]  # forecasts resume within two messages
    values = probe.values()
    assert values["clock resets"] == "2" and values["not forecast inputs"] == "0"
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_diagnostics_say_error_while_inputs_are_refused() -> None:
    forecaster = make_node(Predictor.from_checkpoint(), NodeOptions(name="gt_refused"))
    probe = Probe()
    t = START_S
    for _ in range(3):
        t += 0.4
        assert probe.send(_walkers(t), forecaster)
    levels = []
    started = time.monotonic()
    while time.monotonic() - started < 1.6:  # a tracker gone to a moving frame
        t += 0.4
        assert probe.send(_walkers(t, frame="base_link"), forecaster)
        levels.append(probe.got["diagnostics"][-1].status[0].level[0])
        time.sleep(0.3)
    assert levels[0] != ERROR and levels[-1] == ERROR
    assert "inputs refused for" in probe.got["diagnostics"][-1].status[0].message
    t += 0.4
    assert probe.send(_walkers(t), forecaster)
    assert probe.got["diagnostics"][-1].status[0].level[0] == OK  # forecasting again
    assert int(probe.values()["malformed inputs"]) == len(levels)
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_a_reused_id_gives_no_fast_forecast_and_a_warning_naming_it(
    caplog: pytest.LogCaptureFixture,
) -> None:
    forecaster = make_node(Predictor.from_checkpoint(), NodeOptions(name="gt_reuse"))
    probe = Probe()
    worst = 0.0
    for k in range(60):
        if 30 <= k < 35:
            continue  # person 7 unseen for 0.5 s, then its id on someone 4 m away
        x = 0.13 * k if k < 30 else 0.13 * 30 + 4.0 - 0.13 * (k - 35)
        people = Tracked(START_S + 0.1 * k, "map", ["7"], np.array([[x, 0.0]]))
        before = len(probe.got["forecasts"])
        assert probe.send(people, forecaster)
        if len(probe.got["forecasts"]) > before and _forecast_people(probe):
            sent = probe.got["forecasts"][-1]
            path = [[x, 0.0]] + [
                [p.transforms[0].translation.x, p.transforms[0].translation.y] for p in sent.points
            ]
            metres = np.linalg.norm(np.diff(np.array(path), axis=0), axis=1).sum()
            worst = max(worst, metres / (0.4 * len(sent.points)))
    assert "id 7 reappeared where no walker gets to" in caplog.text
    assert probe.values()["id restarts"] == "1"
    assert worst < 3.0  # m/s
    forecaster.destroy_node()
    probe.node.destroy_node()


def test_a_restart_with_state_resumes_the_same_radii(tmp_path: Path) -> None:
    state = str(tmp_path / "state")
    options = NodeOptions(name="gt_state", state=state)
    first = make_node(Predictor.from_checkpoint(), options, online=True)
    probe = Probe()
    for k in range(30):
        assert probe.send(_walkers(START_S + 0.4 * k), first)
    assert first.session.online.scored.sum() > 0  # radii moved with the truths
    radii = first.session.online.radii.copy()
    first.stop()  # as at Ctrl-C: the state is kept
    first.destroy_node()
    second = make_node(Predictor.from_checkpoint(), options, online=True)
    np.testing.assert_array_equal(second.session.online.radii, radii)
    np.testing.assert_array_equal(second.session.online.scored, first.session.online.scored)
    second.destroy_node()
    probe.node.destroy_node()


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_the_command_within_a_second_and_it_says_so(
    stop: signal.Signals, tiny_checkpoints: Path
) -> None:
    from diagnostic_msgs.msg import DiagnosticArray

    checkpoint = tiny_checkpoints / "grouptron-eth-backward"
    command = [sys.executable, "-m", "grouptron", "ros2", "--checkpoint", str(checkpoint)]
    command += ["--learn", "--ros-args", "-p", "topic:=/sigint_people"]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ)
    )
    watcher = rclpy.create_node(f"watch_{random.randint(0, 10**6)}")
    said: list[Any] = []
    watcher.create_subscription(DiagnosticArray, "/diagnostics", said.append, 10)
    try:
        deadline = time.monotonic() + 90
        while not said and time.monotonic() < deadline and process.poll() is None:
            rclpy.spin_once(watcher, timeout_sec=0.1)  # the node runs: it says so each second
        assert said, process.stderr.read() if process.poll() is not None else "no diagnostics"
        sent = time.monotonic()
        process.send_signal(stop)
        code = process.wait(timeout=10)
        took_s = time.monotonic() - sent
        end = time.monotonic() + 2
        while time.monotonic() < end and said[-1].status[0].level[0] != STALE:
            rclpy.spin_once(watcher, timeout_sec=0.05)
    finally:
        process.kill()
        watcher.destroy_node()
    stderr = process.stderr.read()
    assert code == 0 and "Traceback" not in stderr, stderr[-2000:]
    assert took_s < 1.0, took_s
    assert said[-1].status[0].level[0] == STALE and said[-1].status[0].message == "stopped"
