"""``grouptron ros2``: a live node, or a bag replayed on the graph (the work:
:mod:`grouptron.ros2`)."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

from grouptron.errors import GrouptronError

EXTRA = "pip install 'grouptron[ros2]'"


def cmd_ros2(args: argparse.Namespace) -> int:
    """Run the node (or the replay) until Ctrl-C, SIGTERM or ``--seconds``."""
    try:
        import rclpy
    except ImportError:
        raise GrouptronError(f"grouptron ros2 needs rclpy: {EXTRA}") from None
    import torch

    torch.set_num_threads(args.threads)
    # A replay ends at Ctrl-C as any command does; the node stops on its own terms.
    stop = None if args.replay else _stop_on_signals()
    _init(rclpy, args.ros_args, own_signals=stop is not None)
    try:
        code = _replay(args) if stop is None else _run_node(args, stop)
    except KeyboardInterrupt:
        return 0
    finally:
        rclpy.try_shutdown()
    if stop is not None and stop.is_set():
        _exit_now(code)
    return code


def _exit_now(code: int) -> None:
    """End the process now, everything written and flushed: stopped by a signal, a node ends
    within a second, and PyTorch's own teardown at exit would take a good part of it."""
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _run_node(args: argparse.Namespace, stop: threading.Event) -> int:
    """The node, until ``stop`` (a signal), ROS shuts down or ``--seconds``; then its last
    status, its state and ``--save-site`` kept."""
    node = _node(args)
    if args.save_site and not args.lifecycle and node.session.learning is None:
        raise GrouptronError("--save-site keeps what the node learns: add --learn")
    try:
        _spin(node, args.seconds, stop)
    finally:
        node.stop()  # the last diagnostics, the state kept, the learning process stopped
        session = getattr(node, "session", None)  # a lifecycle node's, while configured
        if args.save_site and session is not None and session.learning is not None:
            weights = session.save_site(args.save_site)  # kept however the node stopped
            print(f"kept the site's weights in {weights}", flush=True)
        node.destroy_node()
    return 0


def _stop_on_signals() -> threading.Event:
    """An event set by SIGINT or SIGTERM: the node stops between updates, says so and exits
    with code 0 (rclpy's own handler would shut the context down under a publishing node)."""
    stop = threading.Event()

    def handle(signum: int, frame: Any) -> None:
        stop.set()

    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, handle)
    return stop


def _init(rclpy: Any, ros_args: list[str], *, own_signals: bool = False) -> None:
    """rclpy, with the arguments after ``--ros-args``; arguments ROS does not know are one
    line."""
    try:
        from rclpy.signals import SignalHandlerOptions

        rclpy.init(
            args=["grouptron", "--ros-args", *ros_args] if ros_args else None,
            # With our own handlers (_stop_on_signals), rclpy installs none.
            signal_handler_options=SignalHandlerOptions.NO if own_signals else None,
        )
    except Exception as error:
        raise GrouptronError(
            f"--ros-args {' '.join(ros_args)}: ROS does not read these ({error}); --ros-args "
            "comes last, after grouptron's own options"
        ) from None


def _replay(args: argparse.Namespace) -> int:
    """Publish the bag's people on the graph at their recorded rate."""
    import rclpy

    from grouptron.ros2.replay import replay_bag

    node = rclpy.create_node("grouptron_replay")
    count = replay_bag(node, Path(args.replay), args.topic, args.out_topic)
    print(f"published {count} messages of {args.topic} on {args.out_topic}")
    return 0


def _node(args: argparse.Namespace) -> Any:
    """The forecasting node the options describe."""
    from grouptron.cli.learning import learning_options
    from grouptron.inference.predictor import Predictor
    from grouptron.ros2.node import NodeOptions, make_node

    def predictor() -> Predictor:  # a lifecycle node loads it when configured
        chosen = {"forecast": args.forecast, "calibration": args.calibration}
        return Predictor.from_checkpoint(args.checkpoint, threads=args.threads, **chosen)

    options = NodeOptions(
        topic=args.topic,
        type=args.type,
        ros_fields=args.ros_fields,
        fixed_frames=tuple(args.fixed_frame or ()),
        regions=args.regions or 0.0,
        markers=args.markers,
        state=args.state,
        odom=args.odom or "",
        sensor_pose=args.sensor_pose or "",
        costmap=args.costmap,
    )
    print(f"forecasting {args.topic} ({args.type}) on /grouptron/forecasts", flush=True)
    learn, lifecycle = learning_options(args), args.lifecycle
    loaded = predictor if lifecycle else predictor()
    return make_node(loaded, options, online=args.online, learn=learn, lifecycle=lifecycle)


def _spin(node: Any, seconds: float | None, stop: threading.Event) -> None:
    """Spin ``node`` until ``stop`` is set, ROS shuts down or ``seconds`` have passed, on one
    executor kept for the whole run (``rclpy.spin_once`` builds its wait set anew at every
    call); a spin waits at most 50 ms, so a signal is answered within one update."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    executor = SingleThreadedExecutor()
    executor.add_node(node)
    deadline = time.monotonic() + seconds if seconds else None
    try:
        while (
            not stop.is_set() and rclpy.ok() and (deadline is None or time.monotonic() < deadline)
        ):
            executor.spin_once(timeout_sec=0.05)
    except ExternalShutdownException:
        pass  # ROS was shut down from outside: stop as for Ctrl-C
    finally:
        executor.remove_node(node)
