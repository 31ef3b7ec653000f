"""The parser of ``grouptron report`` (its handlers: ``grouptron.cli.report``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    METRICS_HELP,
    REPORT_CHECKPOINTS,
    Formatter,
    add_data_options,
    add_threads_option,
    metric_names,
    non_negative_int,
)
from grouptron.constants import (
    DEFAULT_CHECKPOINT,
    EVALUATION_MODES,
    REPORT_NLL_MAX_SAMPLES,
    SPLITS,
)
from grouptron.geometry import DERIVATIVE_SCHEMES
from grouptron.presets import MODEL_NAMES


# A flat list of options, each with its help: long, but one thing to read.
def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    report = commands.add_parser(
        "report",
        help="regenerate the paper's tables from a folder of checkpoints",
        description="Evaluate every best.safetensors in the folders of --checkpoints "
        "on its test set (and univ ones on UNIV-40/45/50), with constant velocity alongside, "
        "and write the Grouptron paper's Tables I and II with our numbers beside the published "
        "ones, the difference in percent, best-of-20, KDE NLL and the reproduction targets. "
        "Per-sample scores are cached, so running it again scores only new or changed "
        "checkpoints and modes.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron report --mode ml --models trajectron++,grouptron --seeds 0   # make demo\n"
        "  grouptron report --mode ml                      # Tables I and II only\n"
        "  grouptron report --out RESULTS.md\n"
        "  grouptron report --split univ --mode ml,best-of-5,best-of-20 --metrics miss-rate-2m\n"
        "  grouptron report --derivatives central --format json --out results.json",
    )
    report.add_argument(
        "--checkpoints", default=REPORT_CHECKPOINTS, help="folder of checkpoint folders"
    )
    report.add_argument(
        "--dataset",
        metavar="FILE",
        help="report on a dataset of your own instead: every checkpoint under --checkpoints "
        "trained on it, and constant velocity, on its test part",
    )
    report.add_argument(
        "--derivatives",
        "--protocol",
        dest="derivatives",
        choices=(*DERIVATIVE_SCHEMES, "both"),
        default="both",
        help="the derivative scheme of the checkpoints to report: central (the papers'), "
        "backward (causal) or both (--protocol is an older name of this option)",
    )
    report.add_argument(
        "--mode",
        default="ml,best-of-20,nll",
        help=f"comma-separated of {', '.join(EVALUATION_MODES)}, ml-topK, best-of-K, or all",
    )
    report.add_argument(
        "--split",
        help=f"regenerate the tables for these test sets only (comma-separated of "
        f"{', '.join(SPLITS)}): their checkpoints and constant velocity on them; the AVG "
        "column needs all five (default: all five)",
    )
    report.add_argument(
        "--metrics",
        type=metric_names,
        default=(),
        metavar="NAME[,NAME...]",
        help=METRICS_HELP + "; a table each, and in JSON",
    )
    report.add_argument(
        "--nll-max-samples",
        type=non_negative_int,
        default=REPORT_NLL_MAX_SAMPLES,
        help="KDE NLL on at most this many seeded random test samples per split (0: all, "
        "hours: the NLL decodes 2000 futures per sample and dominates the run time)",
    )
    report.add_argument(
        "--models",
        help="comma-separated models to report (default: every one found; "
        f"{', '.join(MODEL_NAMES)})",
    )
    report.add_argument(
        "--seeds",
        help="comma-separated training seeds to report (default: every seed found; the "
        "mean +- sd over seeds needs several)",
    )
    report.add_argument("--out", help="write the report here (default: standard output)")
    report.add_argument(
        "--format", choices=("markdown", "json"), default="markdown", help="output format"
    )
    report.add_argument("--seed", type=int, default=0, help="seed of the sampling modes")
    report.add_argument(
        "--diagnostics",
        action="store_true",
        help="also the density table (model minus constant velocity by neighbours within "
        "3 m) and the ablation table (edges, scene inputs taken away); needs the ml mode and "
        "one more ML pass per input a model has",
    )
    report.add_argument(
        "--out-of-domain",
        nargs="+",
        metavar="DATASET",
        help="also an out-of-domain section: every causal checkpoint under --checkpoints and "
        "constant velocity on the test part of each dataset description (recordings from "
        "elsewhere; docs/recordings.md) in each point-forecast --mode (ml, ml-argmax, mean, "
        "ml-top10 or ml-topK), and whether the default "
        "model "
        f"({DEFAULT_CHECKPOINT}) is at or below constant velocity on every recording",
    )
    add_threads_option(report)
    report.add_argument("--quiet", action="store_true", help="no progress output")
    add_data_options(
        report,
        derivatives=False,
        cache_help="rebuild samples and score every checkpoint, reading and keeping nothing "
        "(scores are kept in $GROUPTRON_CACHE/scores, else ~/.cache/grouptron/scores, under a "
        "key of the weights, samples, settings and the code that builds and scores a model; "
        "the folder can be deleted at any time)",
    )
    report.set_defaults(handler="grouptron.cli.report:cmd_report")
