"""Named test subsets, e.g. the dense UNIV-N sets of the Grouptron paper."""

from __future__ import annotations

import re

import numpy as np

from grouptron.data.samples import SampleSet
from grouptron.errors import GrouptronError

_UNIV_N = re.compile(r"^univ-(\d+)$")


def parse_univ_n(subset: str) -> int:
    """``"univ-45"`` -> 45; anything else is refused with a clear message."""
    match = _UNIV_N.match(subset.strip().lower())
    if not match or int(match.group(1)) < 1:
        raise GrouptronError(
            f"unknown subset {subset!r}: expected univ-N with N >= 1 (e.g. univ-40, univ-45)"
        )
    return int(match.group(1))


def univ_n_mask(samples: SampleSet, min_present: int) -> np.ndarray:
    """(S,) True for samples whose scene has at least ``min_present`` pedestrians at ``t``."""
    return samples.num_present >= min_present
