"""``grouptron groups``: detect groups and score them against human labels."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from grouptron.cli.common import (
    read_track_table,
)
from grouptron.config import DataConfig, GroupConfig
from grouptron.data.scene import Scene, build_scene
from grouptron.errors import GrouptronError
from grouptron.groups.clustering import LINKAGES
from grouptron.groups.distances import DISTANCE_KINDS
from grouptron.groups.labels import apply_id_map, read_group_labels, read_id_map
from grouptron.groups.scene import (
    StepGroups,
    groups_per_step,
    position_grid,
    score_against_labels,
)
from grouptron.io import refuse_folder, write_csv_atomically
from grouptron.presets import DETECTION_GROUPS
from grouptron.viz.files import check_picture_path
from grouptron.viz.groups import plot_step_groups


def _group_configs(args: argparse.Namespace) -> list[GroupConfig]:
    """The grouping(s) asked for: the threshold rule (the default) or C(N), per linkage and
    distance ('all' compares them)."""
    base = DETECTION_GROUPS if args.rule == "threshold" else GroupConfig()
    linkages = LINKAGES if args.linkage == "all" else (args.linkage or base.linkage,)
    distances = DISTANCE_KINDS if args.distance == "all" else (args.distance,)
    by_threshold = args.rule == "threshold"
    threshold_options = (args.max_distance, args.velocity_weight, args.max_group_size)
    if not by_threshold and any(o is not None for o in threshold_options):
        raise GrouptronError(
            "--max-distance, --velocity-weight and --max-group-size set the threshold rule; "
            "--rule count takes none of them"
        )
    max_distance_m = (
        DETECTION_GROUPS.max_distance_m if args.max_distance is None else args.max_distance
    )
    weight_s = (
        DETECTION_GROUPS.velocity_weight_s if args.velocity_weight is None else args.velocity_weight
    )
    size = DETECTION_GROUPS.max_group_size if args.max_group_size is None else args.max_group_size
    return [
        dataclasses.replace(
            base,
            linkage=link,
            distance=dist,
            max_distance_m=max_distance_m if by_threshold else None,
            velocity_weight_s=weight_s if by_threshold else 0.0,
            max_group_size=(size or None) if by_threshold else None,
        )
        for link in linkages
        for dist in distances
    ]


def _track_scene(args: argparse.Namespace) -> Scene:
    table = read_track_table(args, args.frames_per_step)
    return build_scene(table, DataConfig(frames_per_step=table.frames_per_step), str(args.tracks))


def cmd_groups_evaluate(args: argparse.Namespace) -> int:
    """``grouptron groups evaluate``: score detected groups against labelled ones (pair
    precision, recall, F1, Dice) for each rule, linkage and distance, as a table or JSON."""
    scene = _track_scene(args)
    labels = read_group_labels(args.labels)
    if not labels:
        raise GrouptronError(f"{args.labels}: no pedestrian ids (one group per line)")
    if args.id_map:
        labels = apply_id_map(labels, read_id_map(args.id_map))
    if not set(labels) & set(scene.ped_id.tolist()):
        raise GrouptronError(
            f"none of the {len(labels)} pedestrian ids of {args.labels} is an id of "
            f"{args.tracks}; if the files number people differently, map them with --id-map"
        )
    rows = []
    for config in _group_configs(args):
        scores = score_against_labels(scene, labels, config, every=args.every)
        for scope, values in scores.items():
            rows.append(
                {
                    "scope": scope,
                    "rule": "count" if config.max_distance_m is None else "threshold",
                    "linkage": config.linkage,
                    "distance": config.distance,
                    "max_distance_m": config.max_distance_m,
                    "velocity_weight_s": config.velocity_weight_s,
                    "max_group_size": config.max_group_size,
                    **values,
                }
            )
    if not any(row["decisions"] for row in rows):
        raise GrouptronError(
            f"{args.tracks}: no step has two or more pedestrians tracked over 2 or more steps, "
            "so there is no pair to score"
        )
    if args.format == "json":
        # NaN (no decision of a kind) is not JSON: write null.
        clean = [{k: None if v != v else v for k, v in row.items()} for row in rows]
        document = {"tracks": str(args.tracks), "labels": str(args.labels), "results": clean}
        print(json.dumps(document, indent=2))
        return 0
    header = (
        f"{'scope':<9} {'rule':<9} {'linkage':<9} {'distance':<10} {'precision':>9} {'recall':>7} "
        f"{'F1':>6} {'Dice':>6} {'decisions':>9}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        print(
            f"{r['scope']:<9} {r['rule']:<9} {r['linkage']:<9} {r['distance']:<10} "
            f"{r['pair_precision']:>9.3f} {r['pair_recall']:>7.3f} {r['pair_f1']:>6.3f} "
            f"{r['dice']:>6.3f} {r['decisions']:>9}"
        )
    return 0


def cmd_groups_detect(args: argparse.Namespace) -> int:
    # Every output checked before the work, so that a bad one leaves no file behind.
    """``grouptron groups detect``: the groups of every step as ``frame,id,group`` CSV rows
    (to ``--out`` or standard output), with ``--plot`` a picture of one step."""
    if args.out:
        refuse_folder(Path(args.out), inputs=(args.tracks,))
    if args.frame is not None and not args.plot:
        raise GrouptronError("--frame picks the step --plot draws: give --plot too")
    if args.plot:
        check_picture_path(Path(args.plot), option="--plot", inputs=(args.tracks,))
    scene = _track_scene(args)
    (config,) = _group_configs(args)
    found = list(groups_per_step(scene, config))
    if not found:
        raise GrouptronError(
            f"{args.tracks}: no pedestrian is tracked over 2 or more steps, so there is "
            "nobody to group"
        )
    chosen = _plotted_step(args, scene, found) if args.plot else None
    rows = [
        (scene.first_frame + f.step * scene.frames_per_step, int(scene.ped_id[track]), int(label))
        for f in found
        for track, label in zip(f.tracks, f.labels, strict=True)
    ]
    if args.out:
        write_csv_atomically(Path(args.out), ("frame", "id", "group"), rows)
        print(f"{len(rows)} rows ({len(found)} steps) written to {args.out}")
    else:
        print("frame,id,group")
        for row in rows:
            print(",".join(str(v) for v in row))
    if chosen is not None:
        pad = DataConfig().history_steps - 1
        pos, present = position_grid(scene, pad)
        window = slice(chosen.step, chosen.step + pad + 1)
        frame = scene.first_frame + chosen.step * scene.frames_per_step
        plot_step_groups(
            pos[chosen.tracks, window] + scene.centre_world_m,
            present[chosen.tracks, window],
            chosen.labels,
            scene.ped_id[chosen.tracks],
            title=f"{Path(args.tracks).name}, frame {frame}: {len(chosen.tracks)} pedestrians, "
            f"{len(np.unique(chosen.labels))} groups ({config.linkage} linkage)",
            out=Path(args.plot),
        )
        print(f"plot of frame {frame} written to {args.plot}")
    return 0


def _plotted_step(args: argparse.Namespace, scene: Scene, found: list[StepGroups]) -> StepGroups:
    """The step ``--plot`` draws: ``--frame``'s, or the one with the most pedestrians."""
    if args.frame is None:
        return max(found, key=lambda f: len(f.tracks))
    step, rest = divmod(args.frame - scene.first_frame, scene.frames_per_step)
    matches = [f for f in found if f.step == step]
    if rest or not matches:
        raise GrouptronError(f"frame {args.frame} is not a frame of {args.tracks}")
    return matches[0]
