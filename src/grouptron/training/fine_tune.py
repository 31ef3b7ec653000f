"""A fixed budget of optimiser steps on a model in place: the rounds of online learning.

``grouptron adapt`` runs the whole training loop (a run folder, metrics, a card); a live
session's rounds need only the steps, on weights already in memory, with the step count (and
so the KL and logit-clip schedules) carried from one round to the next as if the rounds were
one fine-tune cut into pieces.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.groups.assign import SampleGroups
from grouptron.model.forecaster import Forecaster
from grouptron.training.distributed import SINGLE
from grouptron.training.run_state import TrainState
from grouptron.training.trainer import TrainingPass, train_step


@dataclass(frozen=True)
class FineTune:
    """One round's budget.

    Attributes:
        steps: optimiser steps (batches drawn with replacement from the samples).
        batch_size: samples a step.
        learning_rate: Adam's (fresh moments every round; fp32).
    """

    steps: int = 60
    batch_size: int = 64
    learning_rate: float = 3e-4


def fine_tune(
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    groups: SampleGroups | None,
    budget: FineTune,
    *,
    rng: np.random.Generator,
    iteration: int,
) -> int:
    """Train ``model`` in place for ``budget.steps`` steps on ``samples`` (with their
    ``groups`` for a model that reads them), the schedules at ``iteration`` onwards; returns
    the step count after the round. Non-finite steps are skipped, as in training."""
    # fp32 whatever the checkpoint trained in: a round is too short to earn back bf16's
    # measured start-up, and half the machines compute bf16 ten times slower.
    config = dataclasses.replace(config, train=dataclasses.replace(config.train, bf16=False))
    optimizer = torch.optim.Adam(model.parameters(), lr=budget.learning_rate)
    constant = torch.optim.lr_scheduler.ExponentialLR(optimizer, 1.0)
    state = TrainState(model, optimizer, constant, rng, iteration=iteration)
    model.train()
    network = TrainingPass(model)
    for _ in range(budget.steps):
        index = rng.choice(len(samples), size=min(budget.batch_size, len(samples)))
        terms = train_step(
            state, config, samples, index, groups=groups, cluster=SINGLE, network=network
        )
        if terms is not None:
            state.iteration += 1
    model.eval()
    return state.iteration
