"""ROS 2 habits: the example parameters file starts the node with the values it names, and
the lifecycle node follows its transitions (real rclpy graph)."""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from grouptron.inference.predictor import Predictor
from grouptron.ros2.messages import Tracked
from grouptron.ros2.node import NodeOptions, make_node
from tests.conftest import REPO
from tests.helpers.ros2_graph import Probe

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.usefixtures("graph")  # rclpy on a domain of its own (conftest)

EXAMPLE = REPO / "docs" / "grouptron.yaml"


def _call(node: Any, client: Any, request: Any, timeout_s: float = 20.0) -> Any:
    assert client.wait_for_service(timeout_sec=timeout_s)
    future = client.call_async(request)
    deadline = time.monotonic() + timeout_s
    while not future.done() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    assert future.done()
    return future.result()


def test_the_example_parameters_file_starts_the_node_with_its_values(
    tiny_checkpoints: Path, tmp_path: Path
) -> None:
    from rcl_interfaces.srv import GetParameters

    document = yaml.safe_load(EXAMPLE.read_text())
    values = document["grouptron"]["ros__parameters"]
    values |= {"markers": "off", "regions": 0.5, "namespace": "/from_file"}  # not the flags'
    path = tmp_path / "grouptron.yaml"
    path.write_text(yaml.safe_dump({"grouptron": {"ros__parameters": values}}))
    command = [sys.executable, "-m", "grouptron", "ros2", "--seconds", "60", "--checkpoint"]
    command += [str(tiny_checkpoints / "grouptron-eth-backward")]
    command += ["--ros-args", "--params-file", str(path)]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ)
    )
    asker = rclpy.create_node(f"asker_{random.randint(0, 10**6)}")
    try:
        names = sorted(values)
        client = asker.create_client(GetParameters, "/grouptron/get_parameters")
        answer = _call(asker, client, GetParameters.Request(names=names), timeout_s=90)
        assert asker.count_publishers("/from_file/forecasts") == 1
        assert asker.count_publishers("/from_file/markers") == 0  # markers: off
    finally:
        process.terminate()
        asker.destroy_node()
    assert process.wait(timeout=10) == 0, process.stderr.read()[-2000:]
    got = {}
    for name, value in zip(names, answer.values, strict=True):
        got[name] = (
            value.string_value,
            value.bool_value,
            value.integer_value,
            value.double_value,
            list(value.string_array_value),
        )[{4: 0, 1: 1, 2: 2, 3: 3, 9: 4}[value.type]]
    assert got == values


def test_the_lifecycle_node_publishes_only_while_active() -> None:
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState

    loads: list[int] = []

    def load() -> Predictor:
        loads.append(1)
        return Predictor.from_checkpoint()

    node = make_node(load, NodeOptions(name="gt_life"), lifecycle=True)
    probe = Probe()
    change = probe.node.create_client(ChangeState, "/gt_life/change_state")
    state = probe.node.create_client(GetState, "/gt_life/get_state")
    spinning = [node, probe.node]

    def step(transition: int) -> None:
        request = ChangeState.Request()
        request.transition.id = transition
        future = change.call_async(request)
        deadline = time.monotonic() + 30
        while not future.done() and time.monotonic() < deadline:
            for n in spinning:
                rclpy.spin_once(n, timeout_sec=0.01)
        assert future.result().success, transition

    def label() -> str:
        future = state.call_async(GetState.Request())
        while not future.done():
            for n in spinning:
                rclpy.spin_once(n, timeout_sec=0.01)
        return future.result().current_state.label

    def walkers(k: int) -> Tracked:
        t = 1_700_000_000.0 + 0.4 * k
        return Tracked(t, "map", ["1", "2"], np.array([[0.5 * k, 0.0], [0.5 * k, 2.0]]))

    assert change.wait_for_service(timeout_sec=10)
    assert label() == "unconfigured" and not loads
    step(Transition.TRANSITION_CONFIGURE)
    assert label() == "inactive" and loads == [1]  # configure loads the model
    for k in range(3):  # inactive: nothing is published, not even diagnostics
        assert not probe.send(walkers(k), node, wait_s=0.5)
    assert not probe.got["forecasts"] and not probe.got["diagnostics"]
    step(Transition.TRANSITION_ACTIVATE)
    for k in range(3, 6):
        assert probe.send(walkers(k), node)
    assert len(probe.got["forecasts"][-1].joint_names) == 2
    step(Transition.TRANSITION_DEACTIVATE)
    forecasts = len(probe.got["forecasts"])
    diagnostics = len(probe.got["diagnostics"])
    for k in range(6, 8):
        probe.send(walkers(k), node, wait_s=0.5)
    assert len(probe.got["forecasts"]) == forecasts
    assert len(probe.got["diagnostics"]) == diagnostics
    step(Transition.TRANSITION_CLEANUP)
    assert label() == "unconfigured" and not hasattr(node, "session")  # freed
    step(Transition.TRANSITION_CONFIGURE)  # configured again: parameters declared before
    assert loads == [1, 1]
    node.destroy_node()
    probe.node.destroy_node()
