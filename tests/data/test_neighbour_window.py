"""DataConfig.neighbour_window_steps: the reference scene graph's window as a leak diagnostic
(neighbours chosen by future contacts), the causal rule unchanged."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from grouptron.config import DataConfig, ExperimentConfig
from grouptron.data.datasets.dataset import cache_key
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.samples import scene_samples
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.inference.predictor import Predictor
from grouptron.model.factory import build_model
from tests.helpers.models import SMALL


def _approaching_pair(data: DataConfig):
    """Walker 0 stands at the origin; walker 1 comes from 7 m at 1 m per step: within 3 m
    from step 4 on. Samples at step 1 (t): 6 m apart, contact 3 steps later."""
    rows = [(10 * s, 0, 0.0, 0.0) for s in range(12)]
    rows += [(10 * s, 1, 7.0 - s, 0.0) for s in range(8)]
    table = table_from_values(Path("pair"), np.array(rows, dtype=float), np.arange(len(rows)))
    samples = scene_samples(build_scene(table, data), data, 2, require_future=False)
    at_t = samples.step == 1
    return samples, np.flatnonzero(at_t & (samples.track == 0))[0]


def test_a_future_window_finds_the_walker_met_later_and_the_causal_rule_does_not() -> None:
    for window, found in (((0, 0), False), ((-2, 2), False), ((-2, 4), True)):
        data = DataConfig(derivatives="backward", neighbour_window_steps=window)
        samples, ego = _approaching_pair(data)
        count = samples.nbr_offsets[ego + 1] - samples.nbr_offsets[ego]
        assert count == int(found), window
    causal, _ = _approaching_pair(DataConfig(derivatives="backward"))
    leaky, _ = _approaching_pair(DataConfig(derivatives="backward", neighbour_window_steps=(-2, 4)))
    assert causal.num_neighbours.sum() < leaky.num_neighbours.sum()
    # At every sample the causal neighbours are among the window's.
    assert (causal.num_neighbours <= leaky.num_neighbours).all()


def test_the_window_is_checked_cached_apart_and_refused_live(tmp_path: Path) -> None:
    with pytest.raises(GrouptronError, match="neighbour_window_steps"):
        DataConfig(neighbour_window_steps=(1, 4))
    files = [tmp_path / "a.txt"]
    files[0].write_text("0 1 0 0\n")
    causal = cache_key(files, DataConfig(), 2)
    assert causal == cache_key(files, DataConfig(neighbour_window_steps=(0, 0)), 2)
    assert causal != cache_key(files, DataConfig(neighbour_window_steps=(-2, 4)), 2)
    config = dataclasses.replace(
        ExperimentConfig(model=SMALL), data=DataConfig(neighbour_window_steps=(-2, 4))
    )
    with pytest.raises(GrouptronError, match="cannot forecast live"):
        Predictor(build_model(config), config)
