"""Groups of a track file: detected at every step (``grouptron groups detect``), and scored
against human labels (``grouptron groups evaluate``).

    from grouptron.data.formats.track_files import TrackFile
    from grouptron.workflows.groups import GroupRule, score_groups, scores_table
    print(scores_table(score_groups(TrackFile("biwi_eth.txt"), "eth/groups.txt", GroupRule())))
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, TypeVar

import numpy as np

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.formats.track_files import TrackFile, read_track_file
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.errors import GrouptronError
from grouptron.groups.clustering import LINKAGES, Linkage
from grouptron.groups.distances import DISTANCE_KINDS, DistanceKind
from grouptron.groups.labels import apply_id_map, read_group_labels, read_id_map
from grouptron.groups.scene import (
    StepGroups,
    groups_per_step,
    position_grid,
    score_against_labels,
)
from grouptron.io import refuse_folder, write_csv_atomically
from grouptron.presets import DETECTION_GROUPS, LEARNED_GROUPS, describe_group_rule
from grouptron.viz.files import check_picture_path
from grouptron.viz.groups import plot_step_groups

Choice = TypeVar("Choice", bound=str)
ALL = "all"
"""A ``linkage`` or ``distance`` that compares every one (scoring only)."""


@dataclass(frozen=True)
class GroupRule:
    """How people are grouped.

    Attributes:
        rule: ``threshold`` (merge while groups are at most ``max_distance_m`` apart, the
            detection rule ``DETECTION_GROUPS``; None: this) or ``count`` (the paper's C(N)
            groups).
        linkage: agglomerative linkage (None: the rule's own; ``all``: each of ``LINKAGES``).
        distance: between two trajectories (``all``: each of ``DISTANCE_KINDS``; None:
            Hausdorff).
        max_distance_m: the threshold rule's cut, metres (None: ``DETECTION_GROUPS``').
        velocity_weight_s: seconds per m/s of velocity difference added to a distance
            (threshold rule; None: ``DETECTION_GROUPS``').
        max_group_size: the largest group of the threshold rule or the learned detector (0:
            no limit; None: theirs, 6).
        detector: ``distance`` (the rules above) or ``learned`` (``LEARNED_GROUPS``: the
            shipped pair classifier, docs/groups.md); None: ``learned`` unless an option of
            the distance rule is given.
    """

    rule: Literal["threshold", "count"] | None = None
    linkage: Linkage | Literal["all"] | None = None
    distance: DistanceKind | Literal["all"] | None = None
    max_distance_m: float | None = None
    velocity_weight_s: float | None = None
    max_group_size: int | None = None
    detector: Literal["distance", "learned"] | None = None

    def chosen_detector(self) -> Literal["distance", "learned"]:
        """The detector asked for; without one, the learned detector (better held out than
        the distance rule, docs/groups.md) unless an option of the distance rule is set."""
        if self.detector is not None:
            return self.detector
        distance_rule = (self.rule, self.linkage, self.distance, self.max_distance_m,
                         self.velocity_weight_s)  # fmt: skip
        return "distance" if any(o is not None for o in distance_rule) else "learned"

    def configs(self) -> list[GroupConfig]:
        """The grouping (one per linkage and distance where ``all`` compares them)."""
        if self.chosen_detector() == "learned":
            return [_learned_rule(self)]
        by_threshold = self.rule in (None, "threshold")
        threshold_options = (self.max_distance_m, self.velocity_weight_s, self.max_group_size)
        if not by_threshold and any(o is not None for o in threshold_options):
            raise GrouptronError(
                "--max-distance, --velocity-weight and --max-group-size set the threshold rule; "
                "--rule count takes none of them"
            )
        base = DETECTION_GROUPS if by_threshold else GroupConfig()
        linkages = _one_or_all(self.linkage or base.linkage, LINKAGES, "linkage")
        distances = _one_or_all(self.distance or base.distance, DISTANCE_KINDS, "distance")
        preset = DETECTION_GROUPS  # the threshold rule's settings where none is given
        max_m = preset.max_distance_m if self.max_distance_m is None else self.max_distance_m
        weight_s = self.velocity_weight_s
        weight_s = preset.velocity_weight_s if weight_s is None else weight_s
        size = preset.max_group_size if self.max_group_size is None else self.max_group_size
        return [
            dataclasses.replace(
                base,
                linkage=link,
                distance=dist,
                max_distance_m=max_m if by_threshold else None,
                velocity_weight_s=weight_s if by_threshold else 0.0,
                max_group_size=(size or None) if by_threshold else None,
            )
            for link in linkages
            for dist in distances
        ]


def _learned_rule(rule: GroupRule) -> GroupConfig:
    """``LEARNED_GROUPS`` with ``rule``'s largest group; the distance rule's options refused."""
    given = (rule.rule, rule.linkage, rule.distance, rule.max_distance_m, rule.velocity_weight_s)
    if any(g is not None for g in given):
        raise GrouptronError(
            "--detector learned links the pairs its classifier finds probable enough; --rule, "
            "--linkage, --distance, --max-distance and --velocity-weight set the distance rule"
        )
    size = LEARNED_GROUPS.max_group_size if rule.max_group_size is None else rule.max_group_size
    return dataclasses.replace(LEARNED_GROUPS, max_group_size=size or None)


def _one_or_all(value: str, every: tuple[Choice, ...], name: str) -> tuple[Choice, ...]:
    """``every`` one for ``all``, else ``value`` (one of them)."""
    if value == ALL:
        return every
    chosen = tuple(v for v in every if v == value)
    if not chosen:
        raise GrouptronError(f"unknown {name} {value!r}; choose from {', '.join(every)} or all")
    return chosen


def track_scene(tracks: TrackFile) -> Scene:
    """The scene of a track file (its own frames per step; no checkpoint's settings)."""
    table, _ = read_track_file(tracks)
    data = DataConfig(frames_per_step=table.frames_per_step)
    return build_scene(table, data, str(tracks.path))


# --- evaluate ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class GroupScores:
    """The scores of one grouping in one scope (``scene`` or ``per_ego``) against the labels:
    ``scores`` holds pair_precision, pair_recall, pair_f1, dice (NaN: no decision of a kind),
    decisions and dice_count (``PairCounts.summary``)."""

    scope: str
    config: GroupConfig
    scores: dict[str, float]

    def to_dict(self) -> dict[str, object]:
        """The scope, the grouping's settings and the scores by name."""
        config = self.config
        return {
            "scope": self.scope,
            "detector": config.detector,
            "rule": _rule_name(config),
            "linkage": config.linkage,
            "distance": config.distance,
            "max_distance_m": config.max_distance_m,
            "velocity_weight_s": config.velocity_weight_s,
            "max_group_size": config.max_group_size,
            **self.scores,
        }


def _rule_name(config: GroupConfig) -> str:
    """``learned``, ``threshold`` or ``count`` (the paper's C(N))."""
    if config.detector == "learned":
        return "learned"
    return "count" if config.max_distance_m is None else "threshold"


def score_groups(
    tracks: TrackFile,
    labels: str | Path,
    rule: GroupRule = GroupRule(),
    *,
    id_map: str | Path | None = None,
    every: int = 1,
) -> list[GroupScores]:
    """Pair precision, recall, F1 and Dice (and, scene-wide, G-MITRE and group matches) of the
    groups ``rule`` detects in ``tracks`` against the group label file ``labels`` (ids mapped
    by the ``id_map`` file, if any), for each grouping and scope, at every ``every``-th step."""
    scene = track_scene(tracks)
    labelled = read_group_labels(labels)
    if not labelled:
        raise GrouptronError(f"{labels}: no pedestrian ids (one group per line)")
    if id_map:
        labelled = apply_id_map(labelled, read_id_map(id_map))
    if not set(labelled) & set(scene.ped_id.tolist()):
        raise GrouptronError(
            f"none of the {len(labelled)} pedestrian ids of {labels} is an id of "
            f"{tracks.path}; if the files number people differently, map them with --id-map"
        )
    rows = [
        GroupScores(scope, config, values)
        for config in rule.configs()
        for scope, values in score_against_labels(scene, labelled, config, every=every).items()
    ]
    if not any(row.scores["decisions"] for row in rows):
        raise GrouptronError(
            f"{tracks.path}: no step has two or more pedestrians tracked over 2 or more steps, "
            "so there is no pair to score"
        )
    return rows


def scores_json(tracks: str | Path, labels: str | Path, rows: list[GroupScores]) -> str:
    """``{"tracks", "labels", "results"}`` as indented JSON (a NaN score as null)."""
    clean = [{k: None if v != v else v for k, v in row.to_dict().items()} for row in rows]
    return json.dumps({"tracks": str(tracks), "labels": str(labels), "results": clean}, indent=2)


def scores_table(rows: list[GroupScores]) -> str:
    """One line per grouping and scope: pair precision, recall, F1, Dice and decisions, and
    (scene scope) G-MITRE F1 and the F1 of group matches with all members and two thirds."""
    header = (
        f"{'scope':<9} {'rule':<9} {'linkage':<9} {'distance':<10} {'precision':>9} {'recall':>7} "
        f"{'F1':>6} {'Dice':>6} {'decisions':>9} {'G-MITRE F1':>10} {'exact F1':>8} "
        f"{'2/3 F1':>7}"
    )
    lines = [header, "-" * len(header)]
    for row in rows:
        r = row.to_dict()
        partition = " ".join(
            f"{r[k]:>{w}.3f}" if k in r else f"{'-':>{w}}"
            for k, w in (("gmitre_f1", 10), ("exact_f1", 8), ("two_thirds_f1", 7))
        )
        lines.append(
            f"{r['scope']:<9} {r['rule']:<9} {r['linkage']:<9} {r['distance']:<10} "
            f"{r['pair_precision']:>9.3f} {r['pair_recall']:>7.3f} {r['pair_f1']:>6.3f} "
            f"{r['dice']:>6.3f} {r['decisions']:>9} {partition}"
        )
    return "\n".join(lines)


# --- detect -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class DetectRequest:
    """What ``groups detect`` does.

    Attributes:
        tracks: the track file.
        rule: how people are grouped (one linkage and distance).
        out: the ``frame,id,group`` CSV file to write (None: none; the rows come back).
        plot: a picture of one step's groups to draw (None: none).
        frame: the frame ``plot`` draws, in the file's frames (None: the most crowded step).
    """

    tracks: TrackFile
    rule: GroupRule = GroupRule()
    out: Path | None = None
    plot: Path | None = None
    frame: int | None = None


@dataclass(frozen=True)
class DetectedGroups:
    """The groups of every step: ``rows`` of (frame, id, group), the steps they came from
    (``steps``), the step ``plot`` draws (None without one), the file's scene and the
    grouping."""

    tracks: str | Path
    rows: list[tuple[int, int, int]]
    steps: list[StepGroups]
    plotted: StepGroups | None
    scene: Scene
    config: GroupConfig

    def frame_of(self, step: StepGroups) -> int:
        """The file's frame number of a step."""
        return self.scene.first_frame + step.step * self.scene.frames_per_step


def detect_groups(request: DetectRequest) -> DetectedGroups:
    """The groups of every step of ``request.tracks``; writes ``request.out`` (CSV) and
    checks ``request.plot`` (before the work, so that a bad one leaves no file behind) and its
    frame. :func:`plot_detected` draws the picture."""
    inputs = (request.tracks.path,)
    if request.out:
        refuse_folder(request.out, inputs=inputs)
    if request.frame is not None and not request.plot:
        raise GrouptronError("--frame picks the step --plot draws: give --plot too")
    if request.plot:
        check_picture_path(request.plot, option="--plot", inputs=inputs)
    scene = track_scene(request.tracks)
    (config,) = request.rule.configs()
    found = list(groups_per_step(scene, config))
    if not found:
        raise GrouptronError(
            f"{request.tracks.path}: no pedestrian is tracked over 2 or more steps, so there "
            "is nobody to group"
        )
    chosen = _plotted_step(request, scene, found) if request.plot else None
    rows = [
        (scene.first_frame + f.step * scene.frames_per_step, int(scene.ped_id[track]), int(label))
        for f in found
        for track, label in zip(f.tracks, f.labels, strict=True)
    ]
    if request.out:
        write_csv_atomically(request.out, ("frame", "id", "group"), rows)
    return DetectedGroups(request.tracks.path, rows, found, chosen, scene, config)


def _plotted_step(request: DetectRequest, scene: Scene, found: list[StepGroups]) -> StepGroups:
    """The step the plot draws: ``frame``'s, or the one with the most pedestrians."""
    if request.frame is None:
        return max(found, key=lambda f: len(f.tracks))
    step, rest = divmod(request.frame - scene.first_frame, scene.frames_per_step)
    matches = [f for f in found if f.step == step]
    if rest or not matches:
        raise GrouptronError(f"frame {request.frame} is not a frame of {request.tracks.path}")
    return matches[0]


def plot_detected(detected: DetectedGroups, out: Path) -> int:
    """Draw the groups of ``detected.plotted`` (the last 8 steps of each person) to ``out``;
    returns its frame."""
    chosen, scene = detected.plotted, detected.scene
    if chosen is None:
        raise GrouptronError("no step was chosen to plot: give the request a plot path")
    pad = DataConfig().history_steps - 1
    pos, present = position_grid(scene, pad)  # (N, pad + steps, 2), (N, pad + steps)
    window = slice(chosen.step, chosen.step + pad + 1)
    frame = detected.frame_of(chosen)
    plot_step_groups(
        pos[chosen.tracks, window] + scene.centre_world_m,
        present[chosen.tracks, window],
        chosen.labels,
        scene.ped_id[chosen.tracks],
        title=f"{Path(detected.tracks).name}, frame {frame}: {len(chosen.tracks)} pedestrians, "
        f"{len(np.unique(chosen.labels))} groups ({describe_group_rule(detected.config)})",
        out=out,
    )
    return frame
