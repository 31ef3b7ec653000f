"""Latency of the live ROS 2 node: from publishing a message of tracked people to receiving
its forecast, beside the session update's own time in the same run.

Usage:
    python benchmarks/ros2_latency.py [--people 50] [--messages 200] [--rate 10] [--threads 1]
                                      [--python] [--stress torch|N]

The synthetic crowd of ``benchmarks/streaming.py`` is published as MarkerArray messages at
``--rate`` Hz of wall-clock time (stamped 0.4 s apart, the crowd's own time) on an isolated
domain of this machine; the node (``grouptron ros2``'s, the
default model with its shipped calibration and 90% regions) runs in a process of its own, as
on a robot. Prints the median, 90th and 99th percentile of the
publish-to-forecast-received time and of the node's own update time (its diagnostics), and
the ratios of the first's median and 99th percentile to the update's median, after the first
20 messages; and how many forecasts never came (the node forecasts the newest message only:
at a rate above what it keeps up with, the others are skipped, and counted on
``/diagnostics``). ``--stress torch`` or ``--stress N`` runs another PyTorch process or N busy
processes beside the node for the timed messages (``benchmarks/stress.py``), as a robot's
computer runs SLAM and planning beside it. The forecasts are received as they arrive, serialized
(the time a C++ planner's subscription sees them); ``--python`` receives them as rclpy
messages instead, counting the subscriber's own conversion of 600 transforms into Python.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import random
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from streaming import synthetic_frames
from stress import stress_kind, stressed  # benchmarks/ is on sys.path


def run_node(seconds: float, threads: int, done: Any) -> None:
    """The node, in a process of its own as on a robot, for ``seconds`` or until ``done``."""
    torch.set_num_threads(threads)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from grouptron import Predictor
    from grouptron.ros2.node import NodeOptions, make_node

    rclpy.init()
    node = make_node(Predictor.from_checkpoint(threads=threads), NodeOptions())
    executor = SingleThreadedExecutor()  # as grouptron ros2 spins: one executor, kept
    executor.add_node(node)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not done.is_set():
        executor.spin_once(timeout_sec=0.05)
    node.stop()
    node.destroy_node()
    rclpy.try_shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--people", type=int, default=50)
    parser.add_argument("--messages", type=int, default=200)
    parser.add_argument("--rate", type=float, default=10.0)
    parser.add_argument("--threads", type=int, default=1, help="the node's (grouptron ros2's)")
    parser.add_argument(
        "--stress",
        type=stress_kind,
        help="beside the node while the messages are timed: 'torch' (another PyTorch process) "
        "or a number of busy processes",
    )
    parser.add_argument(
        "--python",
        action="store_true",
        help="receive the forecasts as Python messages (their conversion counted)",
    )
    args = parser.parse_args()
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(10, 99)))
    os.environ["ROS_LOCALHOST_ONLY"] = "1"
    seconds = args.messages / args.rate + 30.0
    context = multiprocessing.get_context("spawn")
    done = context.Event()
    node = context.Process(target=run_node, args=(seconds, args.threads, done), daemon=True)
    node.start()
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Header
    from trajectory_msgs.msg import MultiDOFJointTrajectory
    from visualization_msgs.msg import MarkerArray

    from grouptron.ros2.messages import Tracked, marker_array

    rclpy.init()
    probe = rclpy.create_node("latency_probe")
    publisher = probe.create_publisher(MarkerArray, "/tracked_people", 10)
    received: dict[tuple[int, int], float] = {}
    update_ms: list[float] = []

    def arrived(message: MultiDOFJointTrajectory | bytes) -> None:
        now = time.perf_counter()
        if isinstance(message, bytes):  # CDR: 4 bytes of encapsulation, then the stamp
            stamp = (int.from_bytes(message[4:8], "little", signed=True),
                     int.from_bytes(message[8:12], "little"))  # fmt: skip
        else:
            stamp = (message.header.stamp.sec, message.header.stamp.nanosec)
        received[stamp] = now

    forecasts_said = [0]

    def said(message: DiagnosticArray) -> None:
        values = {kv.key: kv.value for kv in message.status[0].values}
        count = int(values["forecast inputs"])
        if count > forecasts_said[0]:  # a new forecast's (not the once-a-second repeat)
            forecasts_said[0] = count
            update_ms.append(float(values["update time ms"]))

    probe.create_subscription(
        MultiDOFJointTrajectory, "/grouptron/forecasts", arrived, 10, raw=not args.python
    )
    probe.create_subscription(DiagnosticArray, "/diagnostics", said, 10)
    probe_executor = SingleThreadedExecutor()  # one executor, kept: no wait set rebuilt per spin
    probe_executor.add_node(probe)
    frames = synthetic_frames(args.people, args.messages + 10)
    start = 1_700_000_000.0
    warm = 0
    while not received and warm < 240:  # warm up (the model loads): until the node answers
        t = start - 100.0 + 0.4 * warm
        ids, xy = frames[warm % 10]
        header = Header(frame_id="map")
        header.stamp.sec, header.stamp.nanosec = int(t), round((t % 1) * 1e9) % 1_000_000_000
        publisher.publish(marker_array(Tracked(t, "map", [str(int(i)) for i in ids], xy), header))
        end = time.perf_counter() + 0.4
        while time.perf_counter() < end:
            probe_executor.spin_once(timeout_sec=0.01)
        warm += 1
    received.clear()
    update_ms.clear()
    sent: dict[tuple[int, int], float] = {}
    with stressed(args.stress) as beside:
        publish_frames(frames[10:], start, args.rate, publisher, probe_executor, sent)
    latency = [1000 * (received[s] - sent[s]) for s in list(sent)[20:] if s in received]
    own = update_ms[20:]
    lost = len(sent) - 20 - len(latency)
    print(f"{args.people} people, {args.messages} messages at {args.rate:g} Hz, "
          f"{args.threads} threads, {beside}; {lost} forecasts not received")  # fmt: skip
    for name, values in (("publish to forecast received", latency), ("update", own)):
        print(f"{name:>30}: median {statistics.median(values):.1f} ms, "
              f"p90 {float(np.percentile(values, 90)):.1f} ms, "
              f"p99 {float(np.percentile(values, 99)):.1f} ms")  # fmt: skip
    base = statistics.median(own)
    print(f"{'median / update median':>30}: {statistics.median(latency) / base:.2f}")
    print(f"{'p99 / update median':>30}: {float(np.percentile(latency, 99)) / base:.2f}")
    probe.destroy_node()
    rclpy.try_shutdown()
    done.set()
    node.join(timeout=10)


def publish_frames(
    frames: list[tuple[np.ndarray, np.ndarray]],
    start: float,
    rate: float,
    publisher: Any,
    executor: Any,
    sent: dict[tuple[int, int], float],
) -> None:
    """Publish ``frames`` at ``rate`` Hz (stamped 0.4 s apart from ``start``), spinning the
    probe between them; ``sent`` gets each stamp's publishing time."""
    from std_msgs.msg import Header

    from grouptron.ros2.messages import Tracked, marker_array

    for k, (ids, xy) in enumerate(frames):
        t = start + 0.4 * k  # the crowd's own time: it moves 0.4 s per frame
        header = Header(frame_id="map")
        header.stamp.sec, header.stamp.nanosec = int(t), round((t % 1) * 1e9) % 1_000_000_000
        people = Tracked(t, "map", [str(int(i)) for i in ids], np.asarray(xy))
        message = marker_array(people, header)
        sent[(header.stamp.sec, header.stamp.nanosec)] = time.perf_counter()
        publisher.publish(message)
        deadline = time.perf_counter() + 1.0 / rate
        while (left := deadline - time.perf_counter()) > 0:  # block until a message or then
            executor.spin_once(timeout_sec=left)


if __name__ == "__main__":
    main()
