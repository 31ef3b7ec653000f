"""The learned detector's memory of pairs: smoothed while both walk, held while both stand,
the classifier's own otherwise, forgotten when a pair is not near."""

from __future__ import annotations

import numpy as np
import pytest

from grouptron.groups.learned import fit_classifier, learned_distances
from grouptron.groups.pair_features import FEATURES
from grouptron.groups.pair_memory import WALKING_PACE, PairMemory, pair_keys

WALK, STAND = 1.0, 0.0  # mean speeds in the crowd's pace


def _step(memory: PairMemory, keys: np.ndarray, p: list[float], slower: list[float],
          faster: list[float]) -> list[float]:  # fmt: skip
    used = memory.step(keys, np.array(p), np.array(slower), np.array(faster))
    return [round(float(u), 6) for u in used]


def test_keys_are_one_per_unordered_pair() -> None:
    ids = np.array([40, 7, 2**40])  # any integers, large ones too
    keys = pair_keys(ids, np.array([[0, 1], [1, 0], [0, 2], [2, 1]]))
    assert keys[0] == keys[1] and len(set(keys.tolist())) == 3


def test_walking_together_is_smoothed_and_held_while_both_stand() -> None:
    memory = PairMemory(weight=0.5)
    keys = pair_keys(np.array([1, 2]), np.array([[0, 1]]))
    assert _step(memory, keys, [0.8], [WALK], [WALK]) == [0.8]  # first seen: its own
    assert _step(memory, keys, [0.4], [WALK], [WALK]) == [0.6]  # then a mean of the steps
    assert _step(memory, keys, [0.1], [STAND], [STAND]) == [0.6]  # they stopped together
    assert _step(memory, keys, [0.1], [STAND], [STAND]) == [0.6]
    assert _step(memory, keys, [0.0], [STAND], [WALK]) == [0.0]  # one leaves: its own
    assert _step(memory, keys, [0.2], [STAND], [STAND]) == [0.6]  # still remembered
    assert _step(memory, keys, [1.0], [WALK], [WALK]) == [0.8]


def test_a_pair_first_seen_standing_is_read_as_it_is_and_absent_pairs_are_forgotten() -> None:
    memory = PairMemory()
    ids = np.array([5, 6, 7])
    both = pair_keys(ids, np.array([[0, 1], [1, 2]]))
    assert _step(memory, both, [0.1, 0.9], [STAND, WALK], [STAND, WALK]) == [0.1, 0.9]
    assert len(memory) == 1  # the standing pair had nothing to remember
    assert _step(memory, both[:1], [0.3], [STAND], [STAND]) == [0.3]
    assert len(memory) == 0  # the walking pair was not near at that step
    assert _step(memory, both[1:], [0.2], [STAND], [STAND]) == [0.2]


def test_walking_is_measured_against_the_threshold() -> None:
    memory = PairMemory(weight=1.0)
    keys = pair_keys(np.array([1, 2]), np.array([[0, 1]]))
    slow = WALKING_PACE - 1e-3
    _step(memory, keys, [0.9], [WALKING_PACE], [WALKING_PACE])  # just walking: remembered
    assert _step(memory, keys, [0.2], [slow], [slow]) == [0.9]
    with pytest.raises(ValueError, match="weight"):
        PairMemory(weight=0.0)


def test_a_step_without_near_pairs_forgets_them_all() -> None:
    traj = np.array([[[0.0, 0.0]] * 8, [[0.5, 0.0]] * 8, [[9.0, 9.0]] * 8])
    traj[:2] += np.arange(8)[None, :, None] * np.array([0.5, 0.0])  # two walk side by side
    mask = np.ones((3, 8), bool)
    memory = PairMemory()
    classifier = fit_classifier(
        np.random.default_rng(0).normal(size=(30, len(FEATURES))),
        np.arange(30) % 2 == 0,
        steps=5,
        members=1,
    )
    learned_distances(traj, mask, 0.4, classifier, memory, np.array([1, 2, 3]))
    assert len(memory) == 1  # the walking pair
    apart = traj.copy()
    apart[1] += 20.0  # now nobody is within 3 m of anyone
    learned_distances(apart, mask, 0.4, classifier, memory, np.array([1, 2, 3]))
    assert len(memory) == 0
