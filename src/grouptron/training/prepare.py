"""The data of a training run: its training and validation samples, their groups where the
model reads groups, and the training samples' draw weights where a dataset balances its
sources. The one place a run's data is prepared, for ``grouptron train`` and Python alike."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import ExperimentConfig
from grouptron.constants import ALL_LOCATIONS
from grouptron.data.datasets.custom import load_dataset_part, read_dataset, train_sample_weights
from grouptron.data.datasets.dataset import PartData, load_part
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.groups.assign import SampleGroups, assign_groups
from grouptron.groups.cache import load_groups
from grouptron.model.factory import uses_groups


@dataclass(frozen=True)
class TrainingData:
    """What :func:`grouptron.training.trainer.train` reads.

    Attributes:
        train, val: the parts' samples (``val`` empty where nothing is held out).
        train_groups, val_groups: their groups, for models that read groups (else None).
        train_weights: (S,) draw probabilities of the training samples where the dataset
            names its train sources (else None: every epoch is one shuffled pass).
    """

    train: PartData
    val: PartData
    train_groups: SampleGroups | None = None
    val_groups: SampleGroups | None = None
    train_weights: np.ndarray | None = None


def prepare_training_data(
    experiment: ExperimentConfig,
    data_dir: str | Path | None = None,
    *,
    use_cache: bool = True,
    announce: bool = False,
) -> TrainingData:
    """The samples a run of ``experiment`` trains and validates on: its ETH/UCY split (from
    ``data_dir``, default ``$GROUPTRON_DATA``) or its dataset description, with groups for a
    model that reads them (cached for ETH/UCY). ``announce`` prints a line before the
    groups are clustered (the slow part of a first run)."""
    data = experiment.data
    dataset = read_dataset(experiment.dataset) if experiment.dataset else None
    if dataset is not None:
        names = ("train", "val") if "val" in dataset.parts else ("train",)
        parts = [load_dataset_part(dataset, p, data, use_cache=use_cache) for p in names]
    else:
        folder = resolve_data_dir(data_dir)
        names = ("train",) if experiment.split == ALL_LOCATIONS else ("train", "val")
        parts = [load_part(folder, experiment.split, p, data, use_cache=use_cache) for p in names]
    if len(parts) == 1:  # nothing held out: an empty validation part
        nothing = np.zeros(len(parts[0].samples), dtype=bool)
        parts.append(dataclasses.replace(parts[0], samples=parts[0].samples.subset(nothing)))
    weights = train_sample_weights(dataset, parts[0].samples) if dataset is not None else None
    if not uses_groups(experiment):
        return TrainingData(parts[0], parts[1], train_weights=weights)
    if announce:
        print("clustering every sample's neighbours into groups (cached after the first run)")
    if dataset is not None:
        found = [assign_groups(p.samples, experiment.groups, data.position_scale_m) for p in parts]
    else:
        found = [
            load_groups(
                folder,
                experiment.split,
                name,
                data,
                groups=experiment.groups,
                samples=part.samples,
                use_cache=use_cache,
            )
            for name, part in zip(names, parts, strict=False)
        ]
        if len(found) == 1:
            empty = np.zeros(len(parts[0].samples), dtype=bool)
            found.append(found[0].subset(empty, parts[0].samples))
    return TrainingData(parts[0], parts[1], found[0], found[1], weights)
