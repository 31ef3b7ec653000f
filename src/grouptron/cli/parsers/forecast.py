"""The parsers of ``grouptron predict`` and ``plot`` (handlers: ``grouptron.cli.forecast``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    Formatter,
    add_device_option,
    add_forecast_option,
    add_gap_option,
    add_learning_options,
    add_recording_options,
    add_threads_option,
    calibration_option,
    non_negative_int,
    plot_region_probability,
    positive_int,
    region_probabilities,
)
from grouptron.constants import DEFAULT_CHECKPOINT


# A flat list of options, each with its help: long, but one thing to read.
def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    predict = commands.add_parser(
        "predict",
        help="forecast every pedestrian of a track file with a trained checkpoint",
        description="For every pedestrian and frame with 8 observed steps (the last at that "
        "frame; --min-points 2 forecasts from as few as 2), write the 12 predicted positions "
        "as CSV rows 'frame,id,step,x_m,y_m,t_s' (layout 2, docs/guide.md): frame is the "
        "forecast time as the file's own frame number (the nearest one where 0.4 s is not a "
        "whole number of frames; 0.4 s steps from the first time for a file in seconds), t_s "
        "the same time in the file's own seconds, step k (1..12) the position k steps of "
        "0.4 s later, x_m/y_m in metres in the file's frame of reference (converted from "
        "--units). "
        "--forecast samples adds a 'sample' column "
        "and writes --samples futures per pedestrian and frame. The most likely (ml) output "
        "equals what `grouptron evaluate --mode ml` scores.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron predict --checkpoint checkpoints/grouptron-eth-central/best.safetensors \\\n"
        "      --tracks biwi_eth.txt --out forecast.csv\n"
        "  grouptron predict --checkpoint CKPT --tracks tracks.txt --out s.csv --forecast samples",
    )
    predict.add_argument(
        "--checkpoint",
        default=DEFAULT_CHECKPOINT,
        help="a .safetensors checkpoint or a shipped name (the default is the causal model "
        "used where none is named)",
    )
    predict.add_argument(
        "--tracks",
        required=True,
        help="a 'frame id x y' track file, another layout (--columns, --fps, --units; resampled "
        "to 0.4 s steps) or a TrajNet++ .ndjson file",
    )
    predict.add_argument(
        "--out",
        required=True,
        help="CSV file to write ('-': standard output), or a .ndjson file of TrajNet++ "
        "predictions (its tools score it)",
    )
    add_forecast_option(
        predict,
        "which forecast: "
        "ml: the most likely future per pedestrian (the evaluator's); ml-argmax: the most "
        "probable latent value's; mean: the p(z|x)-weighted mean "
        "future; ml-top10 (ml-topK): ml of the 10 (K) most probable latent values only; "
        "samples: --samples sampled futures. Default: the model's own, as in the Python API: "
        "the one stored with it (ml-top2 for the shipped deployment model), else ml-top10 for a "
        "velocity-residual model and ml-argmax otherwise (on recordings from elsewhere the "
        "forecasts closest to the truth; benchmarks/RESULTS.md)",
        samples=True,
    )
    predict.add_argument(
        "--samples", type=positive_int, default=20, help="futures per pedestrian (samples)"
    )
    predict.add_argument("--seed", type=int, default=0, help="seed of --forecast samples")
    predict.add_argument(
        "--regions",
        type=region_probabilities,
        default=(),
        metavar="Q[,Q...]",
        help="add, per forecast point, the ellipse around it that holds probability Q of the "
        "forecast's distribution: columns qQ_major_m, qQ_minor_m (semi-axes, metres) and "
        "qQ_angle_rad (the major axis from +x), e.g. --regions 0.5,0.9 gives q50_* and q90_*. "
        "Their coverage on recordings is measured, not promised: benchmarks/RESULTS.md; "
        "--calibration sizes them for a site. An .mcap --out draws the first Q",
    )
    add_calibration_option(predict)
    add_online_options(predict)
    add_learning_options(predict, save_site=True)
    predict.add_argument(
        "--min-points",
        type=positive_int,
        help="forecast pedestrians with at least this many observed steps in a row, 2 to 8 "
        "(default 8: the samples the evaluator scores; the Python API forecasts from 2)",
    )
    predict.add_argument(
        "--frames-per-step",
        type=positive_int,
        help="frames between steps 0.4 s apart (default: the checkpoint's, 10 for ETH/UCY)",
    )
    add_gap_option(predict)
    add_recording_options(predict)
    add_threads_option(predict)
    add_device_option(predict)
    predict.add_argument("--quiet", action="store_true", help="no progress bar")
    predict.set_defaults(handler="grouptron.cli.forecast:cmd_predict")
    _add_plot(commands)
    _add_calibrate(commands)


def add_calibration_option(parser: argparse.ArgumentParser) -> None:
    """``--calibration FILE`` (predict, plot)."""
    parser.add_argument(
        "--calibration",
        type=calibration_option,
        help="a grouptron calibrate file of this checkpoint: regions take its conformal radii "
        "(q = 0.01, 0.02, ... 0.99). Default: the calibration the checkpoint ships with, where "
        "it has one (for the shipped deployment model: fitted on held-back crowds, "
        "docs/regions.md); 'none' for the model's own uncalibrated regions",
    )


def add_online_options(parser: argparse.ArgumentParser) -> None:
    """``--online`` and ``--online-state FILE`` (predict)."""
    parser.add_argument(
        "--online",
        action="store_true",
        help="replay the file in time order and adapt the regions' radii to every forecast "
        "whose truth has arrived, as a live session does: long-run coverage stays at Q on any "
        "sequence (docs/regions.md, 'Online calibration'); needs --regions",
    )
    parser.add_argument(
        "--joint",
        action="store_true",
        help="whole-path --regions: a forecast's 12 ellipses together hold its whole 4.8 s path "
        "with probability Q (for planners that check a trajectory); needs a calibration",
    )
    parser.add_argument(
        "--online-state",
        metavar="FILE",
        help="with --online: resume the radii from FILE where it exists, and leave them there",
    )


def _add_calibrate(commands: argparse._SubParsersAction) -> None:
    calibrate = commands.add_parser(
        "calibrate",
        help="size a checkpoint's prediction regions for a site, from a recording of it",
        description="Forecast every person of a recording of the site with 8 observed and 12 "
        "future steps, score where the truth fell against each forecast's region, and write the "
        "split-conformal radii per step and probability (a small JSON file). predict, plot and "
        "Predictor(calibration=...) then draw regions of those radii: a new forecast at the site "
        "falls inside its q-region with probability at least q, as long as it is exchangeable "
        "with the recording's (docs/regions.md says when that holds). Calibrate on an earlier "
        "recording than the one you check it on.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron calibrate --tracks monday.csv --columns t,id,x,y --out site.json\n"
        "  grouptron predict --tracks tuesday.csv --columns t,id,x,y --regions 0.9 \\\n"
        "      --calibration site.json --out forecasts.csv",
    )
    calibrate.add_argument(
        "--checkpoint",
        default=DEFAULT_CHECKPOINT,
        help="a .safetensors checkpoint or a shipped name (default: the model predict uses)",
    )
    calibrate.add_argument(
        "--tracks", required=True, help="a recording of the site (any layout predict reads)"
    )
    calibrate.add_argument("--out", required=True, help="the calibration file to write (.json)")
    add_forecast_option(
        calibrate,
        "the point forecast the regions go with (default: the model's own, as for predict)",
        samples=False,
    )
    add_gap_option(calibrate)
    add_recording_options(calibrate)
    add_threads_option(calibrate)
    calibrate.set_defaults(handler="grouptron.cli.calibrate:cmd_calibrate")


# Longer than 60 lines on purpose: one flat list of options, in the order --help shows them.
def _add_plot(commands: argparse._SubParsersAction) -> None:
    plot = commands.add_parser(
        "plot",
        help="draw a checkpoint's forecasts at one frame of a track file",
        description="Draw, at one frame, every pedestrian with 2 or more observed steps (the "
        "Python API's rule; short gaps filled): the observed "
        "path, the recorded future (dotted), the point forecast (dashed) with the regions that "
        "hold 90%% of its distribution 1.2, 2.4, 3.6 and 4.8 s ahead (or sampled futures, thin), "
        "coloured by detected group; axes in metres. --compare adds a second model's panel "
        "beside the first.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron plot --checkpoint checkpoints/grouptron-univ-central/best.safetensors \\\n"
        "      --tracks students003.txt --frame 3000 --out forecast.png\n"
        "  grouptron plot --checkpoint A --compare B --tracks FILE --frame F --out ab.png\n"
        "  grouptron plot --checkpoint A --tracks FILE --frame 3000 --until 3400 --out a.gif",
    )
    plot.add_argument(
        "--checkpoint",
        default=DEFAULT_CHECKPOINT,
        help="a .safetensors checkpoint or a shipped name (the default is the causal model "
        "used where none is named)",
    )
    plot.add_argument("--compare", help="a second checkpoint drawn beside the first")
    plot.add_argument(
        "--tracks",
        required=True,
        help="a track file: 'frame id x y' (ETH/UCY), another layout (--columns, --fps, "
        "--units; resampled to 0.4 s steps; --frame in the file's own frame numbers, --time in "
        "its seconds) or TrajNet++ .ndjson",
    )
    plot.add_argument(
        "--frame",
        type=int,
        help="the frame to forecast from, in the frame numbers predict writes (default: the "
        "frame with the most people, the middle one of several)",
    )
    plot.add_argument(
        "--time",
        type=float,
        help="the time to forecast from, in the file's own seconds (its t values; frame / fps "
        "for frame numbers): the nearest 0.4 s step",
    )
    plot.add_argument(
        "--until",
        type=int,
        help="animate every step from --frame to this frame (the --out file is then a .gif, "
        "or a .mp4 when ffmpeg is installed; 2.5 pictures per second = real time)",
    )
    plot.add_argument("--out", required=True, help="PNG file to write (.gif/.mp4 with --until)")
    add_forecast_option(
        plot,
        "the dashed point forecast: ml (most likely, the evaluator's), ml-argmax (the "
        "most probable latent value's), mean (the p(z|x)-weighted mean) or ml-top10 (ml-topK: "
        "ml of the 10 (K) most probable latent values) (default: the model's own, as for "
        "predict)",
        samples=False,
    )
    plot.add_argument(
        "--region",
        type=plot_region_probability,
        default=0.9,
        metavar="Q",
        help="draw the regions holding probability Q of each forecast (0: none)",
    )
    plot.add_argument(
        "--samples", type=non_negative_int, default=0, help="sampled futures drawn as thin lines"
    )
    plot.add_argument("--ids", action="store_true", help="write each person's id beside them")
    add_calibration_option(plot)
    plot.add_argument(
        "--online",
        action="store_true",
        help="draw the regions with the radii an online calibration has in force at the frame, "
        "the file replayed from its start (docs/regions.md, 'Online calibration')",
    )
    plot.add_argument("--seed", type=int, default=0, help="seed of the samples")
    plot.add_argument("--quiet", action="store_true", help="no progress bar")
    add_threads_option(plot)
    add_device_option(plot)
    add_gap_option(plot)
    add_recording_options(plot)
    plot.set_defaults(handler="grouptron.cli.forecast:cmd_plot")
