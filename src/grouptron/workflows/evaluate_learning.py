"""Online learning scored: each recording replayed in time order learning its site as a live
session would (``inference.learn_replay``), its later part scored with the weights in use at
each forecast's time, beside the fixed model and constant velocity on the same samples.

    from grouptron.workflows.evaluate_learning import LearningEvaluation, evaluate_learning
    rows = evaluate_learning(LearningEvaluation(Tracks(("site.txt",))))
    print(learning_table(rows))
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grouptron.baselines.constant_velocity import constant_velocity
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.evaluation.recordings import training_files
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.inference.learn_replay import forecast_by_version, replay_learning
from grouptron.inference.learning import LearningOptions, LearningStatus
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.model.predict import default_point_forecast

log = logging.getLogger(__name__)

POOLED = "pooled"


@dataclass(frozen=True)
class LearningEvaluation:
    """What to score.

    Attributes:
        sources: the recordings, each read as its ``TrackSource`` says, each its own site.
        checkpoint: the model the sessions start from.
        options: how the sessions learn.
        scored_from: the part scored: forecasts made from this share of each recording's
            duration on (0.5: its later half; the learning runs from the start).
        progress: progress bars.
    """

    sources: tuple[TrackSource, ...]
    checkpoint: str | Path = DEFAULT_CHECKPOINT
    options: LearningOptions = field(default_factory=LearningOptions)
    scored_from: float = 0.5
    progress: bool = False

    def __post_init__(self) -> None:
        if not self.sources:
            raise GrouptronError("scoring online learning needs at least one track file")
        if not 0 <= self.scored_from < 1:
            raise GrouptronError(f"--scored-from is a share from 0 to 1, not {self.scored_from}")


@dataclass(frozen=True)
class LearningScores:
    """One recording's (or all pooled) FDE on its scored part, in metres.

    Attributes:
        name: the file's name, or ``pooled``.
        samples: forecasts scored.
        fixed_fde, learnt_fde, constant_velocity_fde: the model as shipped, with online
            learning, and constant velocity, on the same samples.
        difference: learnt minus fixed, paired (95% interval over time steps).
        status: the learning's status at the recording's end (None for the pooled row).
        replay_s: wall-clock seconds of the replay with learning (0 for the pooled row).
    """

    name: str
    samples: int
    fixed_fde: float
    learnt_fde: float
    constant_velocity_fde: float
    difference: Interval
    status: LearningStatus | None
    replay_s: float = 0.0

    @property
    def ratio(self) -> float:
        """Learnt FDE over the fixed model's."""
        return self.learnt_fde / self.fixed_fde


@dataclass(frozen=True)
class _Errors:
    fixed: np.ndarray  # (S,) final errors, metres
    learnt: np.ndarray
    constant_velocity: np.ndarray
    steps: np.ndarray  # (S,) time-step ids, distinct across recordings


def evaluate_learning(request: LearningEvaluation) -> list[LearningScores]:
    """A row per recording, then the pooled row (with more than one)."""
    path = resolve_checkpoint(request.checkpoint)
    model, experiment = load_trained_model(path)
    files = [Path(s.path) for s in request.sources]
    for seen in training_files(files, experiment):
        log.warning("%s is part of the data %s trained on: not a held-out score", seen, path)
    forecast = default_point_forecast(experiment)
    data = experiment.data
    rows, pooled, offset = [], [], 0
    for source in request.sources:
        source = dataclasses.replace(source, on_gap=data.on_gap)
        table, _ = read_track_file(source, data.frames_per_step, data.dt_s)
        scene = build_scene(table, data, name=Path(source.path).name)
        samples = scene_samples(scene, data, data.history_steps)
        samples = samples.subset(samples.step >= request.scored_from * scene.num_steps)
        if not len(samples):
            raise GrouptronError(f"{source.path}: no forecast to score in its scored part")
        started = time.perf_counter()
        replay = replay_learning(
            model,
            experiment,
            forecast,
            scene,
            request.options,
            progress=request.progress,
        )
        replay_s = time.perf_counter() - started
        groups = groups_for_model(samples, experiment)
        options = EngineOptions(distribution=False, batch_size=1024)
        made = forecast_by_version(replay, model, experiment, samples, forecast, groups, options)
        fixed = forecast_samples(model, experiment, samples, forecast, groups, options)
        truth = samples.fut_rel_m[:, -1].astype(np.float64)
        cv = constant_velocity(samples.hist_rel_m.astype(np.float64), data.horizon_steps)
        errors = _Errors(
            fixed=np.linalg.norm(fixed.point[:, -1] - truth, axis=-1),
            learnt=np.linalg.norm(made.point[:, -1] - truth, axis=-1),
            constant_velocity=np.linalg.norm(cv[:, -1] - truth, axis=-1),
            steps=time_step_ids(samples) + offset,
        )
        offset = int(errors.steps.max()) + 1
        rows.append(_scores(Path(source.path).name, errors, replay.status, replay_s))
        pooled.append(errors)
    if len(pooled) > 1:
        joined = _Errors(
            *(np.concatenate(a) for a in zip(*(_fields(e) for e in pooled), strict=True))
        )
        rows.append(_scores(POOLED, joined, None))
    return rows


def _fields(errors: _Errors) -> tuple[np.ndarray, ...]:
    return (errors.fixed, errors.learnt, errors.constant_velocity, errors.steps)


def _scores(
    name: str, errors: _Errors, status: LearningStatus | None, replay_s: float = 0.0
) -> LearningScores:
    return LearningScores(
        name=name,
        samples=len(errors.fixed),
        fixed_fde=float(errors.fixed.mean()),
        learnt_fde=float(errors.learnt.mean()),
        constant_velocity_fde=float(errors.constant_velocity.mean()),
        difference=mean_interval(errors.learnt - errors.fixed, errors.steps),
        status=status,
        replay_s=replay_s,
    )


def learning_table(rows: list[LearningScores]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| recording | samples | fixed FDE | learning FDE | x fixed | learning minus fixed "
        "(95%) | CV FDE | rounds accepted / run |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        d = r.difference
        rounds = "" if r.status is None else f"{r.status.accepted} / {r.status.rounds}"
        lines.append(
            f"| {r.name} | {r.samples} | {r.fixed_fde:.3f} | {r.learnt_fde:.3f} | "
            f"{r.ratio:.3f} | {d.mean:+.3f} [{d.low:+.3f}, {d.high:+.3f}] | "
            f"{r.constant_velocity_fde:.3f} | {rounds} |"
        )
    return "\n".join(lines)


def learning_json(rows: list[LearningScores]) -> str:
    """The rows as JSON (metres; intervals as [low, high])."""
    out = []
    for r in rows:
        row = {
            "recording": r.name,
            "samples": r.samples,
            "fixed_fde": r.fixed_fde,
            "learnt_fde": r.learnt_fde,
            "ratio": r.ratio,
            "difference": r.difference.mean,
            "difference_interval": r.difference.to_list(),
            "constant_velocity_fde": r.constant_velocity_fde,
            "replay_s": r.replay_s,
        }
        if r.status is not None:
            row["learning"] = {
                "rounds": r.status.rounds,
                "accepted": r.status.accepted,
                "rolled_back": r.status.rolled_back,
                "samples": r.status.samples,
            }
        out.append(row)
    return json.dumps(out, indent=2)
