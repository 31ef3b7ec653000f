"""Named test subsets: the dense UNIV-N sets of the Grouptron paper, in two definitions.

``univ-N`` (the paper's Table II, the default): samples at time steps with at least N
*predicted agents*, i.e. at least N test samples (agents with all observed and future points)
at that (scene, step). Scoring the public Trajectron++ univ weights this way reproduces the
paper's Trajectron++ row to within 0.007 m.

``univ-N-present``: samples at time steps with at least N pedestrians *present* (observed at
t, whatever their history or future). It keeps many more samples and does not reproduce the
published row; it stays available for comparison with earlier results of this project.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

import numpy as np

from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError

UnivNDefinition = Literal["predicted", "present"]
UNIV_N_DEFINITIONS: tuple[UnivNDefinition, ...] = ("predicted", "present")
_UNIV_N = re.compile(r"^univ-(\d+)(-present)?$")


@dataclass(frozen=True)
class UnivN:
    """A UNIV-N subset: ``min_agents`` and what is counted at the sample's time step."""

    min_agents: int
    definition: UnivNDefinition = "predicted"

    @property
    def name(self) -> str:
        """The subset's name: ``univ-N``, or ``univ-N-present`` for the present count."""
        suffix = "-present" if self.definition == "present" else ""
        return f"univ-{self.min_agents}{suffix}"


def parse_univ_n(subset: str) -> UnivN:
    """``"univ-45"`` -> UnivN(45) (the paper's); ``"univ-45-present"`` -> the present count."""
    match = _UNIV_N.match(subset.strip().lower())
    if not match or int(match.group(1)) < 1:
        raise GrouptronError(
            f"unknown subset {subset!r}: expected univ-N (time steps with >= N predicted "
            "agents, the paper's) or univ-N-present (>= N pedestrians present), N >= 1"
        )
    return UnivN(int(match.group(1)), "present" if match.group(2) else "predicted")


def time_step_ids(samples: SampleSet) -> np.ndarray:
    """(S,) one integer per distinct (scene, step) of the samples, numbered from 0."""
    keys = np.stack([samples.scene_index, samples.step], axis=1)
    return np.unique(keys, axis=0, return_inverse=True)[1].reshape(-1)


def agents_predicted(samples: SampleSet) -> np.ndarray:
    """(S,) the number of samples (predicted agents) at each sample's (scene, step)."""
    ids = time_step_ids(samples)
    return np.bincount(ids)[ids]


def univ_n_mask(samples: SampleSet, subset: UnivN) -> np.ndarray:
    """(S,) True for the samples of ``subset``; ``samples`` must be a whole test set for the
    ``predicted`` count (a partial set counts only its own samples)."""
    if subset.definition == "present":
        return samples.num_present >= subset.min_agents
    return agents_predicted(samples) >= subset.min_agents


DENSITY_BINS: tuple[tuple[int, int | None], ...] = (
    (0, 0),
    (1, 2),
    (3, 5),
    (6, 9),
    (10, 24),
    (25, None),
)
"""Neighbours within the perception radius (3 m) at t: the density bins of the diagnostics."""


def density_masks(samples: SampleSet) -> dict[str, np.ndarray]:
    """``{"neighbours 3-5": (S,) mask, ...}`` for every density bin, in order."""
    count = samples.num_neighbours
    masks = {}
    for low, high in DENSITY_BINS:
        name = f"{low}" if low == high else f"{low}+" if high is None else f"{low}-{high}"
        upper = count <= high if high is not None else np.ones(len(count), dtype=bool)
        masks[f"neighbours {name}"] = (count >= low) & upper
    return masks
