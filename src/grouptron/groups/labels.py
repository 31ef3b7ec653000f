"""Human group labels: reading them and scoring detected groups against them.

A label file has one group per line (whitespace-separated pedestrian ids). Lines that share an id
are merged (union-find); blank lines are skipped; a first line holding a single number equal to
the count of the remaining lines is a count header, not a group. Anyone on no line walks alone.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.data.formats.fields import read_text_file
from grouptron.errors import DataFormatError


def read_group_labels(path: str | Path) -> dict[int, int]:
    """{pedestrian id: group label} of every pedestrian on some line, overlapping lines merged.

    Raises:
        DataFormatError: for a missing file or a non-integer id (naming the line).
    """
    path = Path(path)
    if not path.is_file():
        raise DataFormatError(path, "not a file" if path.exists() else "file not found")
    lines: list[tuple[int, list[int]]] = []
    for number, line in enumerate(_read_text(path).splitlines(), start=1):
        tokens = line.split()
        if not tokens:
            continue
        values = [_as_float(t) for t in tokens]
        if any(v is None or not v.is_integer() for v in values):
            raise DataFormatError(path, f"expected pedestrian ids, got {line.strip()!r}", number)
        lines.append((number, [int(v) for v in values if v is not None]))
    if lines and len(lines[0][1]) == 1 and lines[0][1][0] == len(lines) - 1 > 0:
        lines = lines[1:]  # a count header
    parent: dict[int, int] = {}

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for _, ids in lines:
        for pid in ids:
            parent.setdefault(pid, pid)
        for pid in ids[1:]:
            parent[find(pid)] = find(ids[0])
    roots = sorted({find(pid) for pid in parent})
    label_of_root = {root: label for label, root in enumerate(roots)}
    return {pid: label_of_root[find(pid)] for pid in sorted(parent)}


def _read_text(path: Path) -> str:
    return read_text_file(path)


def _as_float(token: str) -> float | None:
    try:
        return float(token)
    except ValueError:
        return None


def read_id_map(path: str | Path) -> dict[int, int]:
    """A CSV with header ``track_id,label_id``: {track file id: label file id}.

    Raises:
        DataFormatError: naming the line, for a missing header, a row without exactly two
            integer ids, a track id listed twice, or a file with no rows.
    """
    path = Path(path)
    if not path.is_file():
        raise DataFormatError(path, "not a file" if path.exists() else "file not found")
    with io.StringIO(_read_text(path).removeprefix("\ufeff"), newline="") as handle:
        reader = csv.DictReader(handle)
        if reader.fieldnames is None or {"track_id", "label_id"} - set(reader.fieldnames):
            raise DataFormatError(path, "expected a header line 'track_id,label_id'", 1)
        mapping: dict[int, int] = {}
        line_of: dict[int, int] = {}
        for row in reader:
            number = reader.line_num
            if None in row or None in row.values():
                raise DataFormatError(path, "expected two ids, track_id,label_id", number)
            try:
                track, label = int(row["track_id"]), int(row["label_id"])
            except ValueError:
                raise DataFormatError(
                    path, f"ids must be integers: {row['track_id']!r}, {row['label_id']!r}", number
                ) from None
            if track in mapping:
                raise DataFormatError(
                    path, f"track {track} is mapped twice (also line {line_of[track]})", number
                )
            mapping[track], line_of[track] = label, number
    if not mapping:
        raise DataFormatError(path, "no 'track_id,label_id' rows after the header")
    return mapping


def apply_id_map(labels: dict[int, int], mapping: dict[int, int]) -> dict[int, int]:
    """Group labels keyed by track id: a listed track takes the group of its label id; every
    other id keeps its own label (ids not listed are the same in both files), unless a listed
    track claimed that label id."""
    claimed = set(mapping.values())
    mapped = {track: labels[label] for track, label in mapping.items() if label in labels}
    kept = {pid: g for pid, g in labels.items() if pid not in mapping and pid not in claimed}
    return {**kept, **mapped}


def partition_from_labels(ids: np.ndarray, labels: dict[int, int]) -> np.ndarray:
    """(N,) group labels of pedestrians ``ids``; unlabelled ones get singleton labels."""
    out = np.empty(len(ids), dtype=np.int64)
    next_label = max(labels.values(), default=-1) + 1
    for i, pid in enumerate(ids.tolist()):
        if pid in labels:
            out[i] = labels[pid]
        else:
            out[i] = next_label
            next_label += 1
    return out


@dataclass
class PairCounts:
    """Counts of "same group" decisions over pairs, summed over steps."""

    true_positive: int = 0
    false_positive: int = 0
    false_negative: int = 0
    dice_sum: float = 0.0
    dice_count: int = 0

    def add_pairs(self, predicted_same: np.ndarray, labelled_same: np.ndarray) -> None:
        """Count the true and false positives and false negatives of (P,) boolean
        "same group" decisions, ``predicted_same`` against ``labelled_same``."""
        self.true_positive += int((predicted_same & labelled_same).sum())
        self.false_positive += int((predicted_same & ~labelled_same).sum())
        self.false_negative += int((~predicted_same & labelled_same).sum())

    def add_dice(self, value: float) -> None:
        """Add one partition's Dice score to the running mean."""
        self.dice_sum += value
        self.dice_count += 1

    def summary(self) -> dict[str, float]:
        """Pair precision, recall and F1 and the mean Dice (NaN with nothing to divide by; F1 is 0
        without true positives), with the ``decisions`` and ``dice_count`` behind them."""
        tp, fp, fn = self.true_positive, self.false_positive, self.false_negative
        precision = tp / (tp + fp) if tp + fp else float("nan")
        recall = tp / (tp + fn) if tp + fn else float("nan")
        f1 = 2 * precision * recall / (precision + recall) if tp else 0.0
        return {
            "pair_precision": precision,
            "pair_recall": recall,
            "pair_f1": f1,
            "dice": self.dice_sum / self.dice_count if self.dice_count else float("nan"),
            "decisions": tp + fp + fn,
            "dice_count": self.dice_count,
        }


def same_group_pairs(labels: np.ndarray) -> np.ndarray:
    """(P,) "same group" of every unordered pair i < j of a partition."""
    i, j = np.triu_indices(len(labels), k=1)
    return labels[i] == labels[j]


def dice_of_partitions(predicted: np.ndarray, labelled: np.ndarray) -> float:
    """The paper's Dice score: 2 |groups in both| / (|predicted groups| + |labelled groups|),
    where a group counts as shared only if it has exactly the same members."""

    def groups(labels: np.ndarray) -> set[frozenset[int]]:
        return {frozenset(np.flatnonzero(labels == g).tolist()) for g in np.unique(labels)}

    a, b = groups(predicted), groups(labelled)
    return 2.0 * len(a & b) / (len(a) + len(b))
