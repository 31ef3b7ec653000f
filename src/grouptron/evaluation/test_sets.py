"""The test samples of a split (optionally a UNIV-N subset) with, for Grouptron, their groups."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, GroupConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.subsets import UnivN, univ_n_mask
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.groups.assign import SampleGroups
from grouptron.groups.cache import load_groups


def load_test_set(
    data_dir: Path,
    split: str,
    config: DataConfig,
    subset: UnivN | None = None,
    *,
    group_config: GroupConfig | None = None,
    use_cache: bool = True,
) -> tuple[SampleSet, SampleGroups | None]:
    """A split's test samples, restricted to a UNIV-N ``subset`` when given, and their
    groups when ``group_config`` is given (Grouptron); both cached on disk."""
    samples = load_part(data_dir, split, "test", config, use_cache=use_cache).samples
    if not len(samples):
        raise GrouptronError(
            f"{split}: no test samples (every test sample needs {config.history_steps} "
            f"observed and {config.horizon_steps} future steps)"
        )
    groups = None
    if group_config is not None:
        groups = load_groups(
            data_dir,
            split,
            "test",
            config,
            groups=group_config,
            samples=samples,
            use_cache=use_cache,
        )
    if subset is not None:
        keep = univ_n_mask(samples, subset)
        if not keep.any():
            raise GrouptronError(f"{split}: the test set has no sample in {subset.name}")
        samples, groups = subset_with_groups(samples, groups, keep)
    return samples, groups


def subset_with_groups(
    samples: SampleSet, groups: SampleGroups | None, keep: np.ndarray
) -> tuple[SampleSet, SampleGroups | None]:
    """The samples where the (S,) mask ``keep`` is true, with their groups (if any)."""
    if keep.all():
        return samples, groups
    return samples.subset(keep), groups.subset(keep, samples) if groups is not None else None
