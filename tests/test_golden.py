"""Golden outputs: four frozen checkpoints on a fixed synthetic scene must keep forecasting and
scoring exactly as stored (``tests/golden/compute.py`` says how they were made): the paper's
two models, the default model and ``grouptron-robust-residual`` (every robust switch), each
with every point forecast (``ml``, ``ml-argmax``, ``mean``, ``ml-top10``) and one evaluator
call. Checked by breaking the code on purpose: changing the K that ``ml-top10`` names, scaling the
velocity-residual offset by 0.98, or removing the code path of the ego left out, the scene
layer norm, the mean edge aggregation, the edge count feature or the dilated temporal layers
each fails these tests.

Any change of a prediction head, an encoder, the batching or the loss moves some of these
numbers; a refactoring must not. Tolerances allow for float32 summation order on other CPUs.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.golden import compute

TOLERANCES = {  # (rtol, atol) per output kind; positions in m, covariances in m^2
    "most_likely": (1e-5, 2e-4),
    "samples": (1e-5, 2e-4),
    "mixture_means": (1e-5, 2e-4),
    "mixture_covariances": (1e-3, 1e-7),
    "mixture_log_weights": (1e-5, 2e-4),
    "training_loss": (1e-4, 1e-4),
    "scores": (1e-5, 2e-4),
    "ids": (0.0, 0.0),
    "group": (0.0, 0.0),
}


@pytest.fixture(scope="module")
def golden() -> dict[str, np.ndarray]:
    with np.load(compute.GOLDEN, allow_pickle=False) as stored:
        return {key: stored[key] for key in stored.files}


@pytest.fixture(scope="module")
def now() -> dict[str, np.ndarray]:
    return compute.compute()


def test_the_same_outputs_are_computed(golden: dict[str, np.ndarray], now: dict) -> None:
    assert sorted(now) == sorted(golden)
    assert len(golden) == 4 * 12


@pytest.mark.parametrize("name", compute.CHECKPOINTS)
@pytest.mark.parametrize("output", sorted(TOLERANCES))
def test_outputs_equal_the_golden_values(
    golden: dict[str, np.ndarray], now: dict[str, np.ndarray], name: str, output: str
) -> None:
    rtol, atol = TOLERANCES[output]
    keys = [k for k in golden if k.startswith(f"{name}/") and k.endswith(output)]
    assert keys
    for key in keys:
        assert now[key].shape == golden[key].shape, key
        np.testing.assert_allclose(now[key], golden[key], rtol=rtol, atol=atol, err_msg=key)


def test_the_scene_exercises_groups_and_neighbours(golden: dict[str, np.ndarray]) -> None:
    """The golden scene is not trivial: several forecast agents, more than one group."""
    ids = golden["grouptron-univ-backward/ids"]
    assert len(ids) >= 6
    assert len(np.unique(golden["grouptron-univ-backward/group"])) >= 3
