"""``grouptron ros2``: a live node, or a bag replayed on the graph (the work:
:mod:`grouptron.ros2`)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from grouptron.errors import GrouptronError

EXTRA = "pip install 'grouptron[ros2]'"


def cmd_ros2(args: argparse.Namespace) -> int:
    """Run the node (or the replay) until Ctrl-C or ``--seconds``."""
    try:
        import rclpy
    except ImportError:
        raise GrouptronError(f"grouptron ros2 needs rclpy: {EXTRA}") from None
    import torch

    from grouptron.inference.predictor import Predictor
    from grouptron.ros2.node import NodeOptions, make_node
    from grouptron.ros2.replay import replay_bag

    torch.set_num_threads(args.threads)
    rclpy.init()
    try:
        if args.replay:
            node = rclpy.create_node("grouptron_replay")
            count = replay_bag(node, Path(args.replay), args.topic, args.out_topic)
            print(f"published {count} messages of {args.topic} on {args.out_topic}")
            return 0
        predictor = Predictor.from_checkpoint(
            args.checkpoint, forecast=args.forecast, calibration=args.calibration
        )
        options = NodeOptions(
            topic=args.topic,
            type=args.type,
            ros_fields=args.ros_fields,
            fixed_frames=tuple(args.fixed_frame or ()),
            regions=args.regions or 0.0,
        )
        node = make_node(predictor, options, online=args.online)
        print(f"forecasting {args.topic} ({args.type}) on /grouptron/forecasts", flush=True)
        deadline = time.monotonic() + args.seconds if args.seconds else None
        while rclpy.ok() and (deadline is None or time.monotonic() < deadline):
            rclpy.spin_once(node, timeout_sec=0.05)
        return 0
    except KeyboardInterrupt:
        return 0
    finally:
        rclpy.try_shutdown()
