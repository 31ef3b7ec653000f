"""The parser of ``grouptron evaluate`` (its handlers: ``grouptron.cli.evaluate``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    METRICS_HELP,
    Formatter,
    add_data_options,
    add_device_option,
    add_learning_options,
    add_recording_options,
    add_threads_option,
    calibration_option,
    metric_names,
    region_probabilities,
)
from grouptron.constants import CONSTANT_VELOCITY, EVALUATION_MODES, SPLITS

EXAMPLES = (
    "examples:\n"
    "  grouptron evaluate --tracks corridor.txt --columns id,frame,x,y,z --fps 16 --units cm\n"
    "  grouptron evaluate --model constant-velocity --split all\n"
    "  grouptron evaluate --checkpoint grouptron-eth-central --mode ml\n"
    "  grouptron evaluate --forecasts eth.csv --split eth\n"
    "  grouptron evaluate --checkpoint grouptron-eth-central --mode best-of-5,best-of-20 "
    "--metrics miss-rate-2m\n"
    "  grouptron evaluate --checkpoint CKPT --metrics my_metrics:curvature --format json\n"
    "  grouptron evaluate --checkpoint CKPT --split univ --subset univ-45 --mode all "
    "--format json\n"
    "  grouptron evaluate --model constant-velocity --tracks corridor.txt "
    "--columns id,frame,x,y,z --fps 16 --units cm\n"
    "  grouptron evaluate --tracks site.csv --columns t,id,x,y --regions 0.5,0.9 "
    "--calibration site.json\n"
    "  grouptron evaluate --tracks corridor.txt --columns id,frame,x,y,z --fps 16 --units cm "
    "--learn"
)


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    evaluate = commands.add_parser(
        "evaluate",
        help="score a model on the test sets (ADE/FDE in metres)",
        description="Score a trained checkpoint or the constant-velocity baseline on the test "
        "samples of one or all splits (exactly 8 observed and 12 future steps). Modes: 'ml' "
        "(the mode of the latent mixture at every step, the papers' 'most likely'), "
        "'ml-argmax' (the most probable latent value's mean), 'mean' (the p(z|x)-weighted "
        "mean of every latent value's trajectory), 'ml-top10' ('ml' of the 10 most probable "
        "latent values only), 'best-of-20' (min ADE and min "
        "FDE over 20 samples, taken independently; best-of-K for any K) and 'nll' (KDE NLL "
        "of 2000 samples). Every mean comes with its 95% bootstrap interval over time steps "
        "(in JSON; the table shows FDE's), and the displacement error of every forecast step "
        "(the table: steps 4, 8 and 12; JSON: all 12). "
        "With --split all the unweighted mean over the five splits is added.",
        formatter_class=Formatter,
        epilog=EXAMPLES,
    )
    evaluate.add_argument(
        "--checkpoint",
        help="a .safetensors checkpoint, a training run's folder or a shipped name "
        "(checkpoints/README.md; default: the model predict uses). Constant velocity is "
        "scored beside it on the same samples",
    )
    evaluate.add_argument(
        "--model", choices=(CONSTANT_VELOCITY,), help="score a baseline instead of a checkpoint"
    )
    _add_forecast_file_options(evaluate)
    evaluate.add_argument(
        "--split",
        help=f"one of {', '.join(SPLITS)} or all (default: the checkpoint's split, or all)",
    )
    evaluate.add_argument(
        "--subset",
        help="univ-N: only univ test samples at time steps with >= N predicted agents (the "
        "paper's Table II); univ-N-present: at time steps with >= N pedestrians present",
    )
    _add_scoring_options(evaluate)
    add_learning_options(evaluate, scored=True)
    evaluate.add_argument(
        "--include-seen",
        action="store_true",
        help="score test sets the checkpoint trained or validated on (another split's: leave "
        "one location out trains on it) instead of refusing, the checkpoint's rows there "
        "marked 'not held out' (JSON: held_out false)",
    )
    _add_region_options(evaluate)
    evaluate.add_argument(
        "--format", choices=("table", "json"), default="table", help="output format"
    )
    evaluate.add_argument("--quiet", action="store_true", help="no progress bars")
    add_threads_option(evaluate)
    add_device_option(evaluate)
    _add_other_data_options(evaluate)
    add_recording_options(evaluate)
    add_data_options(evaluate)
    evaluate.set_defaults(handler="grouptron.cli.evaluate:cmd_evaluate")


def _add_scoring_options(evaluate: argparse.ArgumentParser) -> None:
    """What is scored: the modes, the metrics beside ADE and FDE, the seed of the draws."""
    evaluate.add_argument(
        "--mode",
        help=f"comma-separated of {', '.join(EVALUATION_MODES)}, ml-topK (ml of the K most "
        "probable latent values), best-of-K (the best of K samples, seeded per mode), or all "
        "(default: the checkpoint's own point forecast, the one predict writes)",
    )
    evaluate.add_argument(
        "--metrics", type=metric_names, default=(), metavar="NAME[,NAME...]", help=METRICS_HELP
    )
    evaluate.add_argument("--seed", type=int, default=0, help="seed of the sampling modes")


def _add_other_data_options(evaluate: argparse.ArgumentParser) -> None:
    """Data other than the benchmark's test sets, and the diagnostics."""
    evaluate.add_argument(
        "--tracks",
        nargs="+",
        metavar="FILE",
        help="score recordings of your own instead of the benchmark: every (person, step) with "
        "8 observed and 12 future points after resampling to 0.4 s (layout: --columns, --fps, "
        "--units)",
    )
    evaluate.add_argument(
        "--by-density",
        action="store_true",
        help="also score by density: neighbours within 3 m at the forecast step (0, 1-2, 3-5, "
        "6-9, 10-24, 25+)",
    )
    evaluate.add_argument(
        "--ablate",
        metavar="INPUTS",
        help="take inputs away to see what a model uses: 'edges' zeroes the edge encoder's "
        "neighbour input, 'scene' zeroes Grouptron's E_scene (comma-separated)",
    )
    evaluate.add_argument(
        "--dataset",
        metavar="FILE",
        help="score the test part of a dataset of your own (its description file)",
    )


def _add_region_options(evaluate: argparse.ArgumentParser) -> None:
    """Prediction regions scored as metrics."""
    evaluate.add_argument(
        "--regions",
        type=region_probabilities,
        default=(),
        metavar="Q[,Q...]",
        help="also score the point forecast's prediction regions (the ellipses predict "
        "--regions writes): per forecast step the share of true positions inside the "
        "Q-region (coverage-qQ) and its mean area in m^2 (area-qQ), e.g. --regions 0.5,0.9; "
        "the table shows steps 4, 8 and 12 and the mean over the steps, JSON every step. "
        "Compare areas at equal coverage: a smaller region that holds Q is sharper",
    )
    evaluate.add_argument(
        "--calibration",
        metavar="FILE",
        type=calibration_option,
        help="size the --regions with a grouptron calibrate file of this checkpoint and point "
        "forecast; without it the checkpoint's shipped one where it has one for the forecasts "
        "scored, as predict draws them; 'none': the model's own regions, uncalibrated",
    )


def _add_forecast_file_options(evaluate: argparse.ArgumentParser) -> None:
    """Forecast files made by any code, scored instead of a checkpoint."""
    evaluate.add_argument(
        "--forecasts",
        nargs="+",
        metavar="FILE",
        help="score forecasts made by any code instead of a checkpoint, on the test samples of "
        "--split or of --tracks recordings (each found by the recording's own frame number and "
        "person id): CSV rows "
        "'frame,id,step,x_m,y_m' (predict's layout 2; a 'sample' column for sampled futures, "
        "scored best-of-K) or TrajNet++ .ndjson predictions; one file per test recording, "
        "named after it where a split has several (docs/models.md)",
    )
    evaluate.add_argument(
        "--name", help="the forecast files' model name in the rows (default: the file's name)"
    )
    evaluate.add_argument(
        "--allow-missing",
        action="store_true",
        help="score the test samples the --forecasts files have instead of refusing files "
        "that lack some (their count is said)",
    )
