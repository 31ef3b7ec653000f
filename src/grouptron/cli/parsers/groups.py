"""The parser of ``grouptron groups`` (its handlers: ``grouptron.cli.groups``)."""

from __future__ import annotations

import argparse

from grouptron.cli.options import (
    Formatter,
    Parser,
    add_gap_option,
    add_recording_options,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from grouptron.constants import DISTANCE_KINDS, LINKAGES
from grouptron.presets import DETECTION_GROUPS


def _rule_options(parser: argparse.ArgumentParser, *, compare: bool) -> None:
    """How people are grouped: the options of ``groups detect`` and ``groups evaluate``."""
    every = " (all: compare them)" if compare else ""
    parser.add_argument(
        "--rule",
        choices=("threshold", "count"),
        help="the distance rule: threshold (its default): merge while groups are at most "
        "--max-distance apart (chosen on human labels, docs/groups.md); count: the paper's "
        "C(N) = (N + 1) // 2 groups of N people",
    )
    parser.add_argument(
        "--detector",
        choices=("distance", "learned"),
        help="learned: small classifiers of pair features trained on four labelled "
        "recordings, remembering each pair from step to step (better held out, docs/groups.md); "
        "distance: the rule below (default: learned, or distance where an option of the rule "
        "is given)",
    )
    parser.add_argument(
        "--linkage",
        choices=(*LINKAGES, "all") if compare else LINKAGES,
        help=f"agglomerative linkage between clusters{every} (default: single for the "
        "threshold rule, complete for count)",
    )
    parser.add_argument(
        "--distance",
        choices=(*DISTANCE_KINDS, "all") if compare else DISTANCE_KINDS,
        help="the distance rule's distance between two trajectories: Hausdorff (its default), "
        "or its modified (quantile) form" + every,
    )
    parser.add_argument(
        "--max-distance",
        type=positive_float,
        help=f"metres: the threshold rule's cut (default {DETECTION_GROUPS.max_distance_m:g})",
    )
    parser.add_argument(
        "--velocity-weight",
        type=non_negative_float,
        help="seconds: the threshold rule keeps people at least this times their velocity "
        f"difference apart (0: positions only; default {DETECTION_GROUPS.velocity_weight_s:g})",
    )
    parser.add_argument(
        "--max-group-size",
        type=non_negative_int,
        help="the threshold rule or the learned detector makes no group larger than this, so "
        "that a dense crowd is not chained into one (0: no limit; default "
        f"{DETECTION_GROUPS.max_group_size})",
    )


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the command and its options to the ``grouptron`` parser."""
    groups = commands.add_parser(
        "groups",
        help="detect pedestrian groups and score them against human labels",
        description="Group detection: by default a learned detector (small classifiers of "
        "who walks with whom over the last 8 steps, remembering each pair from step to step; "
        "docs/groups.md), or a distance rule: agglomerative clustering of trajectories on "
        "Hausdorff distances, cut at a threshold or, as the Grouptron paper does it, into "
        "C(N) = (N + 1) // 2 groups for N pedestrians.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron groups detect --tracks biwi_eth.txt --out groups.csv --plot groups.png\n"
        "  grouptron groups evaluate --tracks biwi_eth.txt --labels eth/groups.txt",
    )
    group_commands = groups.add_subparsers(
        dest="groups_command", metavar="ACTION", parser_class=Parser
    )

    _add_detect(group_commands)
    _add_evaluate(group_commands)


def _track_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--tracks",
        required=True,
        help="a track file: 'frame id x y' (ETH/UCY), another layout (--columns, --fps, "
        "--units; resampled to 0.4 s steps) or TrajNet++ .ndjson",
    )
    parser.add_argument(
        "--frames-per-step",
        type=positive_int,
        default=10,
        help="frames between annotated steps of a 'frame id x y' file",
    )
    add_gap_option(parser)
    add_recording_options(parser)


def _add_detect(group_commands: argparse._SubParsersAction) -> None:
    detect = group_commands.add_parser(
        "detect",
        help="group ids of every pedestrian at every step",
        description="Cluster the pedestrians present at every step of a track file into "
        "groups and write 'frame,id,group' rows (CSV); optionally plot one step.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron groups detect --tracks students003.txt --out groups.csv\n"
        "  grouptron groups detect --tracks biwi_eth.txt --plot eth.png --frame 5000",
    )
    _track_options(detect)
    detect.add_argument("--out", help="CSV file (default: print to standard output)")
    detect.add_argument("--plot", help="PNG of one step's groups")
    detect.add_argument("--frame", type=int, help="frame to plot (default: the most crowded)")
    _rule_options(detect, compare=False)
    detect.set_defaults(handler="grouptron.cli.groups:cmd_groups_detect")


def _add_evaluate(group_commands: argparse._SubParsersAction) -> None:
    score = group_commands.add_parser(
        "evaluate",
        help="score detected groups against whole-track human labels",
        description="At every step with two or more pedestrians, compare the detected groups "
        "with human labels (one group per line of ids; overlapping lines merged; anyone "
        "unlisted walks alone): precision, recall and F1 of the pairwise 'same group' "
        "decisions, and the paper's Dice score of identical groups; in the 'scene' protocol "
        "also the field's G-MITRE precision, recall and F1 and exact and two-thirds group "
        "matches. Protocol 'scene' clusters everyone present; 'per_ego' clusters each "
        "pedestrian with those within 3 m, as the model does, and scores the ego's pairs.",
        formatter_class=Formatter,
        epilog="examples:\n"
        "  grouptron groups evaluate --tracks biwi_eth.txt --labels eth/groups.txt\n"
        "  grouptron groups evaluate --tracks crowds_zara01.txt --labels zara1/groups.txt "
        "--linkage all --distance all --format json",
    )
    _track_options(score)
    score.add_argument("--labels", required=True, help="group label file")
    score.add_argument("--id-map", help="CSV 'track_id,label_id' when the ids differ")
    _rule_options(score, compare=True)
    score.add_argument(
        "--every",
        type=positive_int,
        default=1,
        help="score every k-th step (the learned detector's memory then sees those steps only)",
    )
    score.add_argument("--format", choices=("table", "json"), default="table", help="output format")
    score.set_defaults(handler="grouptron.cli.groups:cmd_groups_evaluate")
