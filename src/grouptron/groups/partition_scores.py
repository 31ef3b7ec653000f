"""Scores of one partition of people into groups against another, as the group-detection
literature scores them: G-MITRE (Solera et al., TPAMI 2016) and group matches at an overlap
(all members, or two thirds: Setti et al., PLoS ONE 2015), summed over steps.

A partition is an (N,) array of group labels of the same N people on both sides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

EXACT = 1.0
TWO_THIRDS = 2.0 / 3.0


def _groups(labels: np.ndarray) -> list[np.ndarray]:
    """The members (indices) of every group of a partition."""
    order = np.argsort(labels, kind="stable")
    cuts = np.flatnonzero(np.diff(labels[order])) + 1
    return np.split(order, cuts)


def _mitre_links(truth: np.ndarray, other: np.ndarray) -> tuple[int, int]:
    """(links kept, links) of ``truth``'s groups under ``other``: per group S, |S| minus the
    number of pieces ``other`` cuts it into, over |S| - 1. A singleton is linked to a copy of
    itself (Solera et al.'s G-MITRE), which ``other`` keeps only where it is a singleton
    there too."""
    group_of = np.unique(other, return_inverse=True)[1].ravel()  # (N,) other's group 0..G-1
    alone = np.bincount(group_of)[group_of] == 1  # (N,) a singleton in ``other``
    kept = links = 0
    for members in _groups(truth):
        if len(members) == 1:
            kept, links = kept + int(alone[members[0]]), links + 1
            continue
        pieces = len(np.unique(other[members]))
        kept, links = kept + len(members) - pieces, links + len(members) - 1
    return kept, links


def _matches(predicted: np.ndarray, truth: np.ndarray, overlap: float) -> tuple[int, int]:
    """(detected groups that estimate a labelled one, labelled groups estimated), groups of two
    or more: a detected D estimates a labelled G when it holds at least ceil(overlap |G|) of
    G's members and at most |G| - ceil(overlap |G|) people from outside G."""
    detected = [g for g in _groups(predicted) if len(g) > 1]
    labelled = [g for g in _groups(truth) if len(g) > 1]
    if not detected or not labelled:
        return 0, 0
    member = np.zeros((len(detected), len(predicted)), bool)  # (D, N)
    for k, group in enumerate(detected):
        member[k, group] = True
    common = np.stack([member[:, g].sum(axis=1) for g in labelled], axis=1)  # (D, G)
    size_d = member.sum(axis=1)[:, None]  # (D, 1)
    size_g = np.array([len(g) for g in labelled])[None]  # (1, G)
    needed = np.ceil(overlap * size_g - 1e-9)
    estimates = (common >= needed) & (size_d - common <= size_g - needed)  # (D, G)
    return int(estimates.any(axis=1).sum()), int(estimates.any(axis=0).sum())


@dataclass
class PartitionCounts:
    """G-MITRE links and group matches, summed over the steps added."""

    recall_kept: int = 0
    recall_links: int = 0
    precision_kept: int = 0
    precision_links: int = 0
    matched: tuple[list[int], list[int]] = field(default_factory=lambda: ([0] * 4, [0] * 4))
    """Per overlap (all members, two thirds): detected groups matched, detected groups,
    labelled groups matched, labelled groups (groups of two or more)."""

    def add(self, predicted: np.ndarray, truth: np.ndarray) -> None:
        """Add one step's (N,) predicted and labelled partitions of the same people."""
        kept, links = _mitre_links(truth, predicted)
        self.recall_kept, self.recall_links = self.recall_kept + kept, self.recall_links + links
        kept, links = _mitre_links(predicted, truth)
        self.precision_kept += kept
        self.precision_links += links
        detected = sum(len(g) > 1 for g in _groups(predicted))
        labelled = sum(len(g) > 1 for g in _groups(truth))
        for counts, overlap in zip(self.matched, (EXACT, TWO_THIRDS), strict=True):
            found_detected, found_labelled = _matches(predicted, truth, overlap)
            counts[0] += found_detected
            counts[1] += detected
            counts[2] += found_labelled
            counts[3] += labelled

    def summary(self) -> dict[str, float]:
        """G-MITRE precision, recall and F1, and the group matches' precision and recall with
        all members (``exact_``) and with two thirds (``two_thirds_``); NaN with nothing to
        divide by."""
        out = _prf("gmitre", self.precision_kept, self.precision_links, self.recall_kept,
                   self.recall_links)  # fmt: skip
        for name, counts in zip(("exact", "two_thirds"), self.matched, strict=True):
            out.update(_prf(name, counts[0], counts[1], counts[2], counts[3]))
        return out


def _prf(name: str, p_num: int, p_den: int, r_num: int, r_den: int) -> dict[str, float]:
    precision = p_num / p_den if p_den else math.nan
    recall = r_num / r_den if r_den else math.nan
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return {f"{name}_precision": precision, f"{name}_recall": recall, f"{name}_f1": f1}
