"""The report's tables of the metrics beyond ADE and FDE (a miss rate, a metric registered by a
user or named with ``--metrics``): one table per metric, its mean per model, derivatives and
mode on every test set and UNIV-N subset."""

from __future__ import annotations

import math
from collections.abc import Sequence

from grouptron.constants import CONSTANT_VELOCITY
from grouptron.evaluation.metrics import metric_label
from grouptron.evaluation.results import EvaluationResult
from grouptron.reporting.cells import (
    TABLE_I_COLUMNS,
    TABLE_II_COLUMNS,
    Key,
    display_name,
    markdown_table,
    ours_models,
)

COLUMNS = (*TABLE_I_COLUMNS, *TABLE_II_COLUMNS[1:])


def metric_tables(
    rows: dict[Key, EvaluationResult], modes: Sequence[str | None], schemes: Sequence[str]
) -> list[str]:
    """A section per metric the rows hold beyond ADE and FDE: a line per (model, derivatives,
    mode) that has it, a cell per column (``-`` where unscored)."""
    names = dict.fromkeys(n for r in rows.values() for n in r.metrics)
    out: list[str] = []
    for name in names:
        lines = []
        for derivatives in schemes:
            for model in (*ours_models(rows), CONSTANT_VELOCITY):
                for mode in ("ml",) if model == CONSTANT_VELOCITY else modes:
                    cells = [rows.get((model, derivatives, c, mode)) for c in COLUMNS]
                    if any(r is not None and name in r.metrics for r in cells):
                        text = [_cell(r, name) for r in cells]
                        lines.append([display_name(model), derivatives, str(mode), *text])
        if lines:
            header = ["model", "derivatives", "mode", *(display_name(c) for c in COLUMNS)]
            out += ["", f"## {metric_label(name)} (`{name}`)", ""]
            out += markdown_table(header, lines)
    return out


def _cell(row: EvaluationResult | None, name: str) -> str:
    value = row.metrics.get(name) if row is not None else None
    return "-" if value is None or math.isnan(value) else f"{value:.3f}"
