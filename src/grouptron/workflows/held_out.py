"""No score of a checkpoint on its own training data, unless asked and marked so.

``evaluate`` refuses in one line to score a checkpoint on benchmark test recordings or a
dataset's test part that it trained or validated on (``evaluation.recordings.benchmark_seen``:
every other split's test set for a checkpoint of one benchmark split, all of them for an
all-locations checkpoint, byte-for-byte training files for any); with ``include_seen``
(``--include-seen``) it scores them and marks each of the checkpoint's rows there
``held_out=False`` ("not held out" in tables). Track files of one's own the checkpoint
trained, validated or adapted on are scored with a warning (as before) and marked the same.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Sequence
from pathlib import Path

from grouptron.config import ExperimentConfig
from grouptron.constants import ALL_LOCATIONS, CONSTANT_VELOCITY, SPLITS
from grouptron.data.datasets.custom import DatasetDescription
from grouptron.data.datasets.subsets import UnivN, parse_univ_n
from grouptron.errors import GrouptronError
from grouptron.evaluation.recordings import POOLED, benchmark_seen, training_files
from grouptron.evaluation.results import EvaluationResult

INCLUDE_SEEN = "--include-seen"


def unseen_refusal(name: str | None, where: str, why: str, own: str | None) -> GrouptronError:
    """The one-line refusal of a score on data the checkpoint ``name`` trained on."""
    instead = (
        f"score it on its own split (--split {own})"
        if own in SPLITS
        else "score it on recordings it never saw (--tracks, --dataset)"
    )
    return GrouptronError(
        f"{name} is not held out from {where} ({why}): {instead}, or pass {INCLUDE_SEEN} to "
        "score it anyway, its rows marked not held out"
    )


def seen_splits(
    experiment: ExperimentConfig | None,
    name: str | None,
    data_dir: Path,
    splits: Sequence[str],
    include_seen: bool,
) -> set[str]:
    """The ``splits`` whose test recordings ``experiment`` trained or validated on (none for
    constant velocity); refused unless ``include_seen``."""
    if experiment is None:
        return set()
    seen = set()
    for split in splits:
        why = benchmark_seen(experiment, data_dir, split)
        if why is not None and not include_seen:
            raise unseen_refusal(name, f"{split}'s test set", why, experiment.split)
        if why is not None:
            seen.add(split)
    return seen


def seen_dataset_files(
    experiment: ExperimentConfig | None,
    name: str | None,
    source: DatasetDescription,
    include_seen: bool,
) -> list[str]:
    """The files of a dataset's test part that ``experiment`` trained or validated on (byte
    for byte); refused unless ``include_seen``."""
    if experiment is None:
        return []
    seen = training_files(source.files("test"), experiment)
    if seen and not include_seen:
        why = f"it trained or validated on {Path(seen[0]).name}"
        raise unseen_refusal(name, f"{source.name}'s test part", why, experiment.split)
    return seen


def mark_not_held_out(
    rows: Sequence[EvaluationResult], splits: Collection[str]
) -> list[EvaluationResult]:
    """The checkpoint's rows on ``splits`` (a split, file or dataset name) marked not held
    out; constant velocity's (it trains on nothing) unchanged."""
    return [
        dataclasses.replace(r, held_out=False)
        if r.split in splits and r.model != CONSTANT_VELOCITY
        else r
        for r in rows
    ]


def seen_track_names(files: Sequence[Path | str]) -> set[str]:
    """The row names of track files seen in training: each file's, and the pooled row's."""
    return {Path(f).name for f in files} | ({POOLED} if files else set())


def benchmark_splits(
    asked: Sequence[str] | None,
    subset_name: str | None,
    experiment: ExperimentConfig | None,
    name: str | None,
    *,
    include_seen: bool,
) -> tuple[tuple[str, ...], UnivN | None]:
    """The splits to score (``asked``, else the checkpoint's own, or all five) and the UNIV-N
    subset, refused where the checkpoint has no held-out benchmark test set."""
    if experiment is not None and experiment.split == ALL_LOCATIONS and not include_seen:
        raise GrouptronError(
            f"{name} was trained on every ETH/UCY location ({ALL_LOCATIONS}), so no "
            "benchmark test set is held out from it; score it on recordings of your own "
            "(--tracks, --dataset), or pass --include-seen to score it marked not held out"
        )
    if experiment is not None and experiment.dataset and not asked:
        raise GrouptronError(
            f"{name} was trained on a dataset of its own ({experiment.split}), not on a "
            "benchmark split: name the splits to score it on (--split), or score recordings "
            "(--tracks, --dataset)"
        )
    own = (experiment.split,) if experiment and experiment.split in SPLITS else SPLITS
    splits = tuple(asked or own)
    unknown = [s for s in splits if s not in SPLITS]
    if unknown:
        raise GrouptronError(f"unknown split {unknown[0]!r}; choose from {', '.join(SPLITS)}")
    subset = parse_univ_n(subset_name) if subset_name is not None else None
    if subset is not None and splits != ("univ",):
        raise GrouptronError("--subset univ-N needs --split univ")
    return splits, subset
