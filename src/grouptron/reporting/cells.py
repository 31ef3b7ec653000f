"""Shared pieces of the report's Markdown: column sets, display names and cell formats.

Cells print ADE/FDE, the field's order and ``evaluate``'s (the Grouptron paper prints
FDE/ADE); a percent change is (ours - reference) / reference.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from grouptron.constants import CONSTANT_VELOCITY, SPLITS, UNIV_N_PAPER
from grouptron.evaluation.results import MEAN_ROW, EvaluationResult
from grouptron.model.factory import DISPLAY_NAMES, MODEL_NAMES

TABLE_I_COLUMNS = (*SPLITS, MEAN_ROW)
TABLE_II_COLUMNS = ("univ", *(f"univ-{n}" for n in UNIV_N_PAPER))
"""UNIV-N as the paper's Table II evidently counted it: time steps with >= N predicted agents."""
PRESENT_COLUMNS = tuple(f"univ-{n}-present" for n in UNIV_N_PAPER)
"""UNIV-N counting pedestrians present at the time step (this project's earlier definition)."""
DISPLAY = {
    **DISPLAY_NAMES,
    CONSTANT_VELOCITY: "constant velocity",
    MEAN_ROW: "AVG",
    "social-stgcnn": "Social-STGCNN",  # the learned baselines (grouptron.baselines)
    "transformer": "Transformer (small)",
}
OURS_MODELS = MODEL_NAMES
TARGET_TOLERANCE = 0.05
"""The reproduction targets: within 5% of the published row on every split."""

Key = tuple[str, str | None, str, str | None]  # model, derivatives, column, mode


def display_name(value: str) -> str:
    """How a model, column or subset is named in the tables (a run named by its settings or
    its class as it is)."""
    if value.endswith("-present"):
        return value.removesuffix("-present").upper() + " (present)"
    if "[" in value or ":" in value:
        return value
    return DISPLAY.get(value, value.upper())


def ours_models(rows: dict[Key, EvaluationResult]) -> tuple[str, ...]:
    """The models of our rows in table order: the named ones, then the runs named by their
    settings or class (ablations, models of the forecaster interface) by name."""
    others = sorted({k[0] for k in rows} - {*OURS_MODELS, CONSTANT_VELOCITY})
    return (*OURS_MODELS, *others)


def column_of(row: EvaluationResult) -> str:
    """The table column of a row: its subset (e.g. ``univ-45``), else its split."""
    return row.subset if row.subset is not None else row.split


def index_rows(rows: Sequence[EvaluationResult]) -> dict[Key, EvaluationResult]:
    """Rows by (model, derivatives, column, mode)."""
    return {(r.model, r.derivatives, column_of(r), r.mode): r for r in rows}


def ade_fde(ade: float, fde: float) -> str:
    """A cell: ADE/FDE in metres."""
    if math.isnan(fde) or math.isnan(ade):
        return "-"
    return f"{ade:.3f}/{fde:.3f}"


def published_pair(values: tuple[float, float]) -> str:
    """A published (FDE, ADE) as ADE/FDE, with the paper's precision: two decimals, three
    where it has them."""
    fde, ade = values
    return "/".join(f"{v:.3f}"[:-1] if f"{v:.3f}".endswith("0") else f"{v:.3f}" for v in (ade, fde))


def percent_change(ours: float, reference: float) -> str:
    """(ours - reference) / reference in percent, signed."""
    return f"{100.0 * (ours - reference) / reference:+.1f}%"


def markdown_table(header: Sequence[str], lines: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table, one string per line."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(line) + " |" for line in lines]
