"""The published rows: their values as the source papers print them, each with its source and
forecast kind, each printed only in the report's table of its kind."""

from __future__ import annotations

import dataclasses

import pytest

from grouptron.constants import DEFAULT_CHECKPOINT
from grouptron.evaluation.results import EvaluationResult
from grouptron.reporting import published
from grouptron.reporting.stats import Report, SeedSpread
from grouptron.reporting.tables import report_markdown

SPLIT_COLUMNS = ("eth", "hotel", "univ", "zara1", "zara2")

EXPECTED = {  # (method, kind): FDE/ADE of ETH, HOTEL, UNIV, ZARA1, ZARA2, AVG
    ("Social-LSTM", "ml"): "2.35/1.09 1.76/0.79 1.40/0.67 1.00/0.47 1.17/0.56 1.54/0.72",
    ("Social-GAN", "best-of-20"): "1.52/0.81 1.61/0.72 1.26/0.60 0.69/0.34 0.84/0.42 1.18/0.58",
    ("SoPhie", "best-of-20"): "1.43/0.70 1.67/0.76 1.24/0.54 0.63/0.30 0.78/0.38 1.15/0.54",
    ("trajectron++", "ml"): "1.68/0.71 0.46/0.22 1.07/0.41 0.77/0.30 0.59/0.23 0.91/0.37",
    ("grouptron", "ml"): "1.56/0.70 0.46/0.21 0.97/0.38 0.76/0.30 0.56/0.22 0.86/0.36",
}
EXPECTED_DENSE = {  # UNIV, UNIV-40, UNIV-45, UNIV-50
    "trajectron++": "1.07/0.41 1.17/0.436 1.24/0.46 1.25/0.47",
    "grouptron": "0.97/0.38 1.00/0.39 1.04/0.40 1.07/0.42",
}


def _printed(row: published.PublishedRow, columns: tuple[str, ...]) -> str:
    return " ".join("/".join(f"{v:g}" for v in row.cells[c]) for c in columns)


def _expected(text: str) -> str:
    return " ".join("/".join(f"{float(v):g}" for v in cell.split("/")) for cell in text.split())


def test_published_values_kinds_and_sources() -> None:
    rows = {(r.method, r.kind): r for r in published.TABLE_I_ROWS}
    assert set(rows) == set(EXPECTED)
    for key, values in EXPECTED.items():
        assert _printed(rows[key], (*SPLIT_COLUMNS, "mean")) == _expected(values), key
    for row in published.TABLE_II_ROWS:
        columns = ("univ", "univ-40", "univ-45", "univ-50")
        assert (row.method, row.kind) in {("trajectron++", "ml"), ("grouptron", "ml")}
        assert _printed(row, columns) == _expected(EXPECTED_DENSE[row.method])
    for row in (*published.TABLE_I_ROWS, *published.TABLE_II_ROWS):
        assert row.source and row.kind in (published.MOST_LIKELY, published.BEST_OF_20)
        if "mean" in row.cells:  # the AVG column is the mean of the five (as printed)
            fde, ade = (sum(row.cells[c][i] for c in SPLIT_COLUMNS) / 5 for i in (0, 1))
            assert row.cells["mean"] == pytest.approx((fde, ade), abs=0.006), row.method
    assert set(published.TABLE_I) == {"Social-LSTM", "trajectron++", "grouptron"}


def _row(model: str, split: str, mode: str, derivatives: str = "central") -> EvaluationResult:
    return EvaluationResult(split, model, None, 10, 0.5, 1.0, mode, None, "x", derivatives)


def _section(text: str, title: str) -> str:
    start = text.index(title)
    end = text.find("\n## ", start + 1)
    return text[start : end if end > 0 else len(text)]


def test_each_published_row_is_printed_in_the_table_of_its_kind_only() -> None:
    rows = [_row("trajectron++", s, m) for s in SPLIT_COLUMNS for m in ("ml", "best-of-20")]
    text = report_markdown(Report(rows, [], []), ("central",), "grouptron report")
    table_i = _section(text, "## Table I")
    best_of = _section(text, "## Best of 20 samples")
    for method in ("Social-GAN", "SoPhie"):
        assert f"| {method} | published |" not in table_i
        assert f"| {method} | published |" in best_of
        assert f"- {method}: Gupta" in best_of or f"- {method}: Sadeghian" in best_of
    assert (
        "| Social-GAN | published | 0.81/1.52 | 0.72/1.61 | 0.60/1.26 | 0.34/0.69 | 0.42/0.84 |"
        in (best_of)
    )
    assert "| Social-LSTM | published |" in table_i and "- Social-LSTM: " in table_i
    assert "| Social-LSTM |" not in best_of
    # Trajectron++'s own best-of-20 row and the learned baselines' papers' rows beside ours
    trajectron = "| Trajectron++ | published | 0.39/0.83 | 0.12/0.21 | 0.20/0.44 | 0.15/0.33 |"
    assert trajectron in best_of and "| Social-STGCNN | published | 0.64/1.11 |" in best_of
    assert "| Grouptron | published |" not in best_of  # its paper prints no best-of-20 row
    assert "the Grouptron paper prints no best-of-20 row" in best_of
    only_ml = [r for r in rows if r.mode == "ml"]
    text = report_markdown(Report(only_ml, [], []), ("central",), "grouptron report --mode ml")
    assert "| Social-GAN |" not in text and "| SoPhie |" not in text


def test_a_model_with_several_seeds_shows_their_mean_spread_and_worst_under_its_row() -> None:
    rows = [_row("trajectron++", s, "ml") for s in SPLIT_COLUMNS]
    univ = dataclasses.replace(rows[2], fde=0.959, ade=0.377)
    rows[2] = univ
    spread = SeedSpread(
        "trajectron++", "central", "univ", (0, 1, 2), (0.959, 1.059, 1.053), (0.377, 0.41, 0.40)
    )
    difference = dataclasses.replace(spread, model="grouptron - trajectron++")
    text = report_markdown(Report(rows, [], [spread, difference]), ("central",), "grouptron report")
    table_i = _section(text, "## Table I")
    assert "| Trajectron++ | ours, central | 0.500/1.000 | 0.500/1.000 | 0.377/0.959 |" in table_i
    assert (
        "|  | seeds 0, 1, 2: FDE mean ± sd (worst) | - | - | 1.024 ± 0.056 (1.059) | - | - | - |"
        in (table_i)
    )
    assert table_i.count("seeds 0, 1, 2") == 1  # a difference's spread is not a model's
    assert f"The shipped default model, `{DEFAULT_CHECKPOINT}`, trained on every" in text
