"""Where a campaign run's text records live once its folder is no longer in the repository.

A run folder (``campaign/runs/<run>``, ``campaign/screen/<run>``) exists only on the machine
that trained it: git ignores both. What a published figure rests on stays tracked, each file
once:

- a shipped run's card, config, metrics log and selection are in its ``checkpoints/<name>/``
  (``records/shipped.tsv`` maps run names to those folders);
- everything else (out-of-domain scores, runs that were never shipped, the campaign logs) is
  in ``campaign/records/runs/<run>/`` and ``campaign/records/logs/``.

``record(folder, "selection.json")`` finds a run's file wherever it is: in the run folder when
this machine has it, else in those places.
"""

from __future__ import annotations

import csv
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RECORDS = REPO / "campaign" / "records"


@cache
def shipped_folders() -> dict[str, Path]:
    """Run name -> the shipped checkpoint folder it became (``records/shipped.tsv``)."""
    with (RECORDS / "shipped.tsv").open(newline="") as table:
        rows = csv.DictReader(table, delimiter="\t")
        return {row["run"]: REPO / row["shipped as"] for row in rows}


def record(run_folder: Path, filename: str) -> Path:
    """The first of ``run_folder/filename``, ``records/runs/<run>/filename`` and
    ``<shipped folder>/filename`` that exists, else ``run_folder/filename`` (absent), so that
    callers keep testing ``.exists()`` as before."""
    name = Path(run_folder).name
    candidates = [Path(run_folder) / filename, RECORDS / "runs" / name / filename]
    if name in shipped_folders():
        candidates.append(shipped_folders()[name] / filename)
    return next((path for path in candidates if path.exists()), candidates[0])
