"""One metrics writer: every record goes to JSONL and CSV, both rewritten atomically."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from grouptron.io import write_csv_atomically, write_text_atomically


class MetricsWriter:
    """Records of ``<dir>/metrics.jsonl`` and ``<dir>/metrics.csv``.

    Both files are rewritten whole (a run has at most a few hundred records) through a
    temporary file, so a crash leaves the previous version, never a torn line. The CSV has a
    column for every key any record has, in order of first appearance.
    """

    def __init__(self, out_dir: Path) -> None:
        self.jsonl = out_dir / "metrics.jsonl"
        self.csv = out_dir / "metrics.csv"

    def write(self, record: dict[str, Any]) -> None:
        """Append ``record`` and rewrite both files."""
        self._save([*self.records(), record])

    def records(self) -> list[dict[str, Any]]:
        """Every record written so far, in order."""
        if not self.jsonl.exists():
            return []
        return [json.loads(line) for line in self.jsonl.read_text().splitlines() if line]

    def truncate_after(self, epoch: int) -> None:
        """Drop records of epochs after ``epoch`` (a resumed run redoes them)."""
        if self.jsonl.exists():
            self._save([r for r in self.records() if r.get("epoch", 0) <= epoch])

    def _save(self, records: list[dict[str, Any]]) -> None:
        write_text_atomically(self.jsonl, "".join(json.dumps(r) + "\n" for r in records))
        columns = list(dict.fromkeys(key for record in records for key in record))
        rows = [[record.get(key, "") for key in columns] for record in records]
        write_csv_atomically(self.csv, columns, rows)
