"""Every sample's groups, cached on disk next to the samples they belong to."""

from __future__ import annotations

import hashlib
import json
import logging
import zipfile
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig, GroupConfig, config_to_dict
from grouptron.data.dataset import cache_key, cache_path, min_history_for, save_npz
from grouptron.data.locate import split_files
from grouptron.data.samples import SampleSet
from grouptron.groups.assign import SampleGroups, assign_groups

log = logging.getLogger(__name__)


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
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as npz:
                return SampleGroups.from_arrays({k: npz[k] for k in npz.files})
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
            log.warning("ignoring unreadable cache file %s (%s); rebuilding", path, exc)
    found = assign_groups(samples, groups, config.position_scale_m)
    try:
        save_npz(path, found.to_arrays())
    except OSError as exc:
        log.warning("could not write the preprocessing cache %s: %s", path, exc)
    return found
