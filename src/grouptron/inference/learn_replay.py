"""A recording replayed in time order with online learning: which weights a live session
would have used at every step, and the forecasts made with them.

The rounds run in line at recording time (``LearningOptions.background`` off), so a replay is
deterministic, and strictly causal: the weights in use at step ``t`` were trained and judged
on samples whose futures had ended before ``t``, read from the recording's rows before ``t``
(a round run at a step's observations serves from the next step, as in a live session).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from tqdm import tqdm

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.data.prepare.scene import Scene
from grouptron.groups.assign import SampleGroups
from grouptron.inference.engine import EngineOptions, Forecasts, forecast_samples
from grouptron.inference.learning import LearningOptions, LearningStatus, SiteLearner
from grouptron.model.forecaster import Forecaster
from grouptron.model.mixture import Mixture
from grouptron.point_forecast import PointForecast


@dataclass(frozen=True)
class Replay:
    """The weights a replay used, by step.

    Attributes:
        models: the weights in use, in order (the first: the model as given).
        from_step: (V,) the scene step from which each one was used.
        learner: the learner (its ``model``: the weights in use at the end).
    """

    models: list[Forecaster]
    from_step: np.ndarray
    learner: SiteLearner

    @property
    def status(self) -> LearningStatus:
        """The learning's status at the recording's end."""
        return self.learner.status

    def version_of(self, steps: np.ndarray) -> np.ndarray:
        """(S,) the index in ``models`` of the weights in use at each of (S,) steps."""
        return np.searchsorted(self.from_step, steps, side="right") - 1


def replay_learning(
    model: Forecaster,
    config: ExperimentConfig,
    forecast: PointForecast,
    scene: Scene,
    options: LearningOptions,
    *,
    progress: bool = False,
) -> Replay:
    """Replay ``scene`` step by step into a learner (rounds in line, at recording time) that
    bridges gaps as a live session does by default."""
    learner = SiteLearner(model, config, forecast, replace(options, background=False))
    models, from_step = [learner.model], [0]
    xy_world = scene.state_scene[:, :2].astype(np.float64) + scene.centre_world_m  # (R, 2)
    order = np.argsort(scene.step, kind="stable")
    steps, starts = np.unique(scene.step[order], return_index=True)
    # Tracks, not the file's ids: a person's pieces split at gaps stay apart, as in the scene.
    for step, rows in tqdm(
        zip(steps, np.split(order, starts[1:]), strict=True),
        total=len(steps),
        disable=not progress,
        desc="replay",
    ):
        # The time a live session fed frame numbers gives the step (frame / frames per step).
        t_s = (scene.first_frame / scene.frames_per_step + float(step)) * scene.dt_s
        learner.observe(t_s, scene.track[rows], xy_world[rows])
        if learner.model is not models[-1]:
            # From the next step, as in a live session, which observes after it forecasts.
            models.append(learner.model)
            from_step.append(int(step) + 1)
    return Replay(models, np.asarray(from_step), learner)


def forecast_by_version(
    replay: Replay | None,
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    forecast: PointForecast,
    groups: SampleGroups | None,
    options: EngineOptions,
) -> Forecasts:
    """Every sample's forecast by the weights in use at its step (``model``'s without a
    replay), in the samples' order."""
    if replay is None:
        return forecast_samples(model, config, samples, forecast, groups, options)
    version = replay.version_of(samples.step)
    parts, index = [], []
    for number in np.unique(version):
        mine = version == number
        part_groups = None if groups is None else groups.subset(mine, samples)
        weights = replay.models[number].to(options.device)
        made = forecast_samples(
            weights, config, samples.subset(mine), forecast, part_groups, options
        )
        parts.append(made)
        index.append(np.flatnonzero(mine))
    back = np.argsort(np.concatenate(index))  # the parts' rows back in the samples' order
    return Forecasts(
        point=np.concatenate([p.point for p in parts])[back],
        distribution=_rows([p.distribution for p in parts], back),
        mixture=_rows([p.mixture for p in parts], back),
        samples=None
        if parts[0].samples is None
        else np.concatenate([p.samples for p in parts if p.samples is not None])[back],
    )


def _rows(parts: list[Mixture | None], back: np.ndarray) -> Mixture | None:
    kept = [p for p in parts if p is not None]
    return Mixture.concatenate(kept).rows(back) if kept else None
