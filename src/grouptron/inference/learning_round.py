"""One round of online learning, as a pure function of its inputs: roll back, fine-tune,
judge (``inference.learning`` says why each step is there). A session runs it in line or in a
worker process (``inference.round_worker``); both give the same result for the same job."""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.groups.assign import SampleGroups
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.model.factory import groups_for_model
from grouptron.model.forecaster import Forecaster
from grouptron.point_forecast import PointForecast
from grouptron.training.fine_tune import FineTune, fine_tune


@dataclass(frozen=True)
class RoundSettings:
    """What every round of a session shares.

    Attributes:
        config: the model's settings; forecast: the point forecast judged (FDE).
        budget: the fine-tune; min_gain: the smallest mean gain accepted, as a share of the
            FDE in use; seed: of the batches, rotations and noise.
    """

    config: ExperimentConfig
    forecast: PointForecast
    budget: FineTune
    min_gain: float
    seed: int


@dataclass(frozen=True)
class RoundJob:
    """One round's inputs.

    Attributes:
        in_use: the weights forecasts use now; adapted: whether they are learnt ones.
        train, holdout: the samples trained on and the fresh ones judged on.
        number: the round's number (seeds it); iteration: fine-tune steps so far.
    """

    in_use: Forecaster
    adapted: bool
    train: SampleSet
    holdout: SampleSet
    number: int
    iteration: int


@dataclass(frozen=True)
class RoundResult:
    """What a round decided.

    Attributes:
        rolled_back: the learnt weights in use did worse than the shipped ones: dropped.
        accepted: the fine-tuned weights that now replace those in use (None: kept).
        difference: the fine-tuned minus in-use paired FDE difference (metres, 95%).
        iteration: fine-tune steps after the round.
    """

    rolled_back: bool
    accepted: Forecaster | None
    difference: Interval
    iteration: int


def judged_round(job: RoundJob, shipped: Forecaster, settings: RoundSettings) -> RoundResult:
    """Roll back to ``shipped`` where the learnt weights in use do worse than it on the fresh
    samples, fine-tune a copy of the weights in use, and accept it only where it forecasts
    better beyond chance and by at least ``min_gain``."""
    config = settings.config
    held_groups = groups_for_model(job.holdout, config)
    in_use, rolled_back = job.in_use, False
    if job.adapted:
        worse, _ = _difference(in_use, shipped, job.holdout, held_groups, settings)
        if worse.low > 0:
            in_use, rolled_back = shipped, True
    candidate = copy.deepcopy(in_use)
    rng = np.random.default_rng([settings.seed, job.number])
    train_groups = groups_for_model(job.train, config)
    iteration = fine_tune(
        candidate,
        config,
        job.train,
        train_groups,
        settings.budget,
        rng=rng,
        iteration=job.iteration,
    )
    difference, fde_in_use = _difference(candidate, in_use, job.holdout, held_groups, settings)
    better = difference.high < 0 and -difference.mean >= settings.min_gain * fde_in_use
    return RoundResult(rolled_back, candidate if better else None, difference, iteration)


def seeded_round(job: RoundJob, shipped: Forecaster, settings: RoundSettings) -> RoundResult:
    """:func:`judged_round` with PyTorch's random state seeded by the round (and the
    caller's left as it was): the same job gives the same result anywhere."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(settings.seed + job.number)
        return judged_round(job, shipped, settings)


def _difference(
    new: Forecaster,
    old: Forecaster,
    samples: SampleSet,
    groups: SampleGroups | None,
    settings: RoundSettings,
) -> tuple[Interval, float]:
    """FDE of ``new`` minus ``old`` on ``samples`` (metres; 95% interval over time steps),
    and ``old``'s mean FDE."""
    device = next(new.parameters()).device
    options = EngineOptions(distribution=False, batch_size=1024, device=device)
    final = samples.fut_rel_m[:, -1].astype(np.float64)  # (S, 2)
    errors = []
    for model in (new, old):
        made = forecast_samples(model, settings.config, samples, settings.forecast, groups, options)
        errors.append(np.linalg.norm(made.point[:, -1] - final, axis=-1))  # (S,)
    difference = mean_interval(errors[0] - errors[1], time_step_ids(samples))
    return difference, float(errors[1].mean())
