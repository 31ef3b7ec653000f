"""One metrics writer: every record goes to JSONL and CSV (columns fixed by the first row)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any


class MetricsWriter:
    """Append records to ``<dir>/metrics.jsonl`` and ``<dir>/metrics.csv``."""

    def __init__(self, out_dir: Path) -> None:
        self.jsonl = out_dir / "metrics.jsonl"
        self.csv = out_dir / "metrics.csv"

    def write(self, record: dict[str, Any]) -> None:
        with self.jsonl.open("a") as handle:
            handle.write(json.dumps(record) + "\n")
        new_file = not self.csv.exists()
        with self.csv.open("a", newline="") as handle:
            fieldnames = list(record) if new_file else self._fieldnames()
            writer = csv.DictWriter(handle, fieldnames=fieldnames, extrasaction="ignore")
            if new_file:
                writer.writeheader()
            writer.writerow(record)

    def records(self) -> list[dict[str, Any]]:
        """Every record written so far, in order."""
        if not self.jsonl.exists():
            return []
        return [json.loads(line) for line in self.jsonl.read_text().splitlines() if line]

    def _fieldnames(self) -> list[str]:
        with self.csv.open() as handle:
            return next(csv.reader(handle))

    def truncate_after(self, epoch: int) -> None:
        """Drop records of epochs after ``epoch`` (a resumed run redoes them)."""
        if not self.jsonl.exists():
            return
        kept = [r for r in self.records() if r.get("epoch", 0) <= epoch]
        self.jsonl.unlink()
        if self.csv.exists():
            self.csv.unlink()
        for record in kept:
            self.write(record)
