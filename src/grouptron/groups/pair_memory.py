"""A learned detector's memory of each pair, step to step: people who stop together stay
together.

A window of two standing people says little about whether they came together: in ZARA2 ten of
the sixteen people who stand for most of their track arrive in a group and stand for some 40 s,
while HOTEL's people waiting at the tram stop stand beside strangers. So while both of a pair
walk, the probability that they walk together is smoothed over the steps (an exponential mean
of the classifier's, which also steadies a pair of strangers briefly in step), and while both
stand it is the one they last walked with. A pair seen for the first time standing, or with
one walking and one standing, is read as the classifier reads it.

Pairs are keyed by their tracks' ids; a pair that is not near each other at a step is
forgotten (they parted, or one was lost).
"""

from __future__ import annotations

import numpy as np

WALKING_PACE = 0.3
"""Walking: a mean speed over the window of at least this share of the crowd's pace (the
``speed_low`` / ``speed_high`` features are in those units)."""
MEMORY_WEIGHT = 0.3
"""The weight of the newest step in the exponential mean while both walk."""
_KEY = np.dtype((np.void, 16))  # two int64 ids as one sortable key


def pair_keys(ids: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """(P,) one key per unordered pair of (P, 2) ``pairs`` of indices into (N,) integer ids."""
    ends = np.sort(ids.astype(np.int64)[pairs], axis=1)  # (P, 2): (i, j) and (j, i) alike
    return np.ascontiguousarray(ends).view(_KEY).ravel()


class PairMemory:
    """What each near pair was last judged while both walked (one per scene or live session;
    steps are fed in order)."""

    def __init__(self, weight: float = MEMORY_WEIGHT) -> None:
        if not 0.0 < weight <= 1.0:
            raise ValueError(f"the memory's weight must be in (0, 1], not {weight}")
        self.weight = weight
        self._keys = np.zeros(0, _KEY)  # (K,) sorted
        self._probability = np.zeros(0)  # (K,)

    def __len__(self) -> int:
        return len(self._keys)

    def forget(self) -> None:
        """Forget every pair (a step where no pair is near, or nobody is present)."""
        self._keys, self._probability = np.zeros(0, _KEY), np.zeros(0)

    def step(
        self,
        keys: np.ndarray,
        probability: np.ndarray,
        slower_pace: np.ndarray,
        faster_pace: np.ndarray,
    ) -> np.ndarray:
        """(P,) the probabilities to link the step's P pairs with, from their (P,) ``keys``
        (:func:`pair_keys`), the classifier's (P,) ``probability`` now and the (P,) mean speeds
        of the slower and the faster of each pair (in the crowd's pace); remembers the step's
        pairs and forgets the rest."""
        known, remembered = self._recall(keys)
        both_walk = slower_pace >= WALKING_PACE
        both_stand = faster_pace < WALKING_PACE
        smoothed = np.where(known, self.weight * probability + (1 - self.weight) * remembered,
                            probability)  # fmt: skip
        used = np.where(both_walk, smoothed, np.where(both_stand & known, remembered, probability))
        keep = both_walk | known  # a pair first seen not both walking has nothing to remember
        stored = np.where(both_walk, smoothed, remembered)[keep]
        order = np.argsort(keys[keep])
        self._keys, self._probability = keys[keep][order], stored[order]
        result: np.ndarray = used
        return result

    def _recall(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P,) whether each key is remembered and (P,) its probability (0 where not)."""
        if not len(self._keys):
            return np.zeros(len(keys), bool), np.zeros(len(keys))
        at = np.minimum(np.searchsorted(self._keys, keys), len(self._keys) - 1)
        known = self._keys[at] == keys
        return known, np.where(known, self._probability[at], 0.0)
