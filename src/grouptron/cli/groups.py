"""``grouptron groups``: detect groups and score them against human labels (the work:
:mod:`grouptron.workflows.groups`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from grouptron.cli.common import track_file
from grouptron.workflows.groups import (
    DetectRequest,
    GroupRule,
    detect_groups,
    plot_detected,
    score_groups,
    scores_json,
    scores_table,
)


def _group_rule(args: argparse.Namespace) -> GroupRule:
    """The grouping the rule options ask for ('all' compares linkages or distances)."""
    return GroupRule(
        rule=args.rule,
        linkage=args.linkage,
        distance=args.distance,
        max_distance_m=args.max_distance,
        velocity_weight_s=args.velocity_weight,
        max_group_size=args.max_group_size,
        detector=args.detector,
    )


def cmd_groups_evaluate(args: argparse.Namespace) -> int:
    """``grouptron groups evaluate``: score detected groups against labelled ones (pair
    precision, recall, F1, Dice) for each rule, linkage and distance, as a table or JSON."""
    rows = score_groups(
        track_file(args), args.labels, _group_rule(args), id_map=args.id_map, every=args.every
    )
    print(
        scores_json(args.tracks, args.labels, rows) if args.format == "json" else scores_table(rows)
    )
    return 0


def cmd_groups_detect(args: argparse.Namespace) -> int:
    """``grouptron groups detect``: the groups of every step as ``frame,id,group`` CSV rows
    (to ``--out`` or standard output), with ``--plot`` a picture of one step."""
    out = Path(args.out) if args.out else None
    plot = Path(args.plot) if args.plot else None
    request = DetectRequest(track_file(args), _group_rule(args), out, plot, args.frame)
    detected = detect_groups(request)
    if out:
        print(f"{len(detected.rows)} rows ({len(detected.steps)} steps) written to {args.out}")
    else:
        print("frame,id,group")
        for row in detected.rows:
            print(",".join(str(v) for v in row))
    if plot:
        frame = plot_detected(detected, plot)
        print(f"plot of frame {frame} written to {args.plot}")
    return 0
