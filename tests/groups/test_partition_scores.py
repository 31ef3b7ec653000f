"""G-MITRE and group matches pinned on hand-made partitions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grouptron.groups.partition_scores import PartitionCounts


def _scores(predicted: list[int], truth: list[int]) -> dict[str, float]:
    counts = PartitionCounts()
    counts.add(np.array(predicted), np.array(truth))
    return counts.summary()


def test_a_perfect_partition_scores_one_everywhere() -> None:
    scores = _scores([0, 0, 1, 2, 2, 2], [5, 5, 6, 7, 7, 7])
    assert all(scores[k] == 1.0 for k in scores)


def test_gmitre_links_singletons_to_themselves() -> None:
    # truth {0,1,2} {3} {4}; predicted {0,1} {2,3} {4}
    scores = _scores([0, 0, 1, 1, 2], [0, 0, 0, 1, 2])
    # recall: {0,1,2} cut in 2 pieces: (3 - 2) of 2 links; {3} is not alone: 0 of 1; {4}: 1 of 1
    assert scores["gmitre_recall"] == pytest.approx(2 / 4)
    # precision: {0,1} one piece: 1 of 1; {2,3} two pieces: 0 of 1; {4} alone: 1 of 1
    assert scores["gmitre_precision"] == pytest.approx(2 / 3)
    assert scores["gmitre_f1"] == pytest.approx(2 * (2 / 3) * 0.5 / (2 / 3 + 0.5))


def test_groups_match_with_all_members_or_two_thirds() -> None:
    # truth {0,1,2} {3,4}; predicted {0,1} {2} {3,4}
    scores = _scores([0, 0, 1, 2, 2], [0, 0, 0, 1, 1])
    assert (scores["exact_precision"], scores["exact_recall"]) == (0.5, 0.5)  # only {3,4}
    # two of {0,1,2}'s three found together (ceil(2/3 * 3) = 2) with no stranger: both
    # labelled groups are estimated, and both detected groups estimate one
    assert (scores["two_thirds_precision"], scores["two_thirds_recall"]) == (1.0, 1.0)
    one_stranger = _scores([0, 0, 1, 0], [0, 0, 0, 1])  # {0,1,3} for {0,1,2}: 3 - 2 allowed
    assert one_stranger["two_thirds_recall"] == 1.0 and one_stranger["exact_recall"] == 0.0
    two_strangers = _scores([0, 0, 1, 0, 0], [0, 0, 0, 1, 2])  # {0,1,3,4}: one too many
    assert two_strangers["two_thirds_recall"] == 0.0


def test_nothing_to_divide_by_is_nan() -> None:
    scores = _scores([0, 1], [0, 1])  # two people alone, both sides
    assert scores["gmitre_f1"] == 1.0 and math.isnan(scores["exact_precision"])
