"""Every sample's groups, cached on disk next to the samples they belong to."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from grouptron.config import DataConfig, GroupConfig, config_to_dict
from grouptron.data.datasets.dataset import cache_key, cache_path, min_history_for
from grouptron.data.datasets.locate import split_files
from grouptron.data.prepare.samples import SampleSet
from grouptron.groups.assign import SampleGroups, assign_groups
from grouptron.io import keep_cache_npz, read_cache_npz


def load_groups(
    data_dir: Path,
    split: str,
    part: str,
    config: DataConfig,
    *,
    groups: GroupConfig,
    samples: SampleSet,
    use_cache: bool = True,
) -> SampleGroups:
    """The groups of a part's samples (see :func:`grouptron.groups.assign.assign_groups`),
    cached next to the samples under a key that adds the group settings."""
    if not use_cache:
        return assign_groups(samples, groups, config.position_scale_m)
    files = split_files(data_dir, split, part)
    payload = json.dumps(
        [cache_key(files, config, min_history_for(part, config)), config_to_dict(groups)]
    )
    key = hashlib.sha256(payload.encode()).hexdigest()[:32]
    path = cache_path(split, part, config, "groups-" + key)
    stored = read_cache_npz(path, SampleGroups.from_arrays)
    if stored is not None:
        return stored
    found = assign_groups(samples, groups, config.position_scale_m)
    keep_cache_npz(path, found.to_arrays())
    return found
