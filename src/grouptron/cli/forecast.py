"""``grouptron predict`` and ``grouptron plot``: forecasts of a track file, as CSV or pictures
(the work: :func:`grouptron.workflows.predict.predict_tracks`,
:func:`grouptron.workflows.plot.plot_tracks`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from grouptron.cli.common import show_progress, track_file
from grouptron.cli.learning import learning_options
from grouptron.viz.foxglove import TOPIC
from grouptron.workflows.plot import PlotRequest, plot_tracks
from grouptron.workflows.predict import PredictRequest, predict_tracks


def _predict_request(args: argparse.Namespace, to_stdout: bool) -> PredictRequest:
    """``grouptron predict``'s options as a request (``to_stdout``: ``--out -``)."""
    return PredictRequest(
        track_file(args),
        sys.stdout if to_stdout else Path(args.out),
        args.checkpoint,
        forecast=args.forecast,
        samples=args.samples,
        seed=args.seed,
        regions=args.regions,
        calibration=args.calibration,
        online=args.online,
        online_state=args.online_state,
        joint=args.joint,
        min_points=args.min_points,
        learn=learning_options(args) or False,
        save_site=args.save_site,
        device=args.device,
        progress=show_progress(args),
    )


def _plot_request(args: argparse.Namespace) -> PlotRequest:
    """``grouptron plot``'s options as a request."""
    return PlotRequest(
        track_file(args),
        Path(args.out),
        args.checkpoint,
        compare=args.compare,
        frame=args.frame,
        until=args.until,
        time_s=args.time,
        forecast=args.forecast,
        region=args.region,
        samples=args.samples,
        seed=args.seed,
        ids=args.ids,
        calibration=args.calibration,
        online=args.online,
        device=args.device,
        progress=show_progress(args),
    )


def cmd_predict(args: argparse.Namespace) -> int:
    """``grouptron predict``: forecast every pedestrian of a track file and write the
    positions as CSV (or ``.ndjson``, ``.mcap``) rows to a file or standard output."""
    to_stdout = args.out == "-"
    torch.set_num_threads(args.threads)
    request = _predict_request(args, to_stdout)
    done = predict_tracks(request)
    if done.learning is not None:
        print(f"learning: {done.learning.line()}", file=sys.stderr)
    if done.scene_updates:
        forecasts = f"{len(done.forecast)} forecasts"
        print(f"wrote {done.count} scene updates ({forecasts}) to {args.out}, topic {TOPIC}")
        return 0
    # The summary goes to standard error when the forecasts go to standard output.
    print(
        f"wrote {done.count} rows for {len(done.forecast)} (pedestrian, frame) pairs "
        f"({done.model_name}, {done.derivatives} derivatives, {done.kind}) to "
        f"{'standard output' if to_stdout else args.out}",
        file=sys.stderr if to_stdout else sys.stdout,
    )
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    """``grouptron plot``: draw forecasts at a frame, or with ``--until`` an animation."""
    torch.set_num_threads(args.threads)
    request = _plot_request(args)
    print(plot_tracks(request).summary)
    return 0
