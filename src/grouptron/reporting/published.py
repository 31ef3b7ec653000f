"""Published FDE/ADE (metres) of the rows the Grouptron paper's Tables I and II print, each
with its source and the forecast it scores.

Keys of a row's cells are our split and subset names; "mean" is the paper's AVG column. Values
are (FDE, ADE), the order the paper prints them in. A row is printed only in the report's
table of its kind: ``ml`` rows (one forecast per person: the most likely, or the one forecast
of a deterministic model) in Tables I and II, ``best-of-20`` rows (the lowest error of 20
sampled futures per person) in the best-of-20 table. The Grouptron paper's Table I prints the
best-of-20 rows of Social-GAN and SoPhie beside the most likely ones without a note; both
values were checked against the source papers as cited (Social-GAN's ZARA2 FDE is 0.84 there,
and its AVG of 1.18 only adds up with it; the Grouptron paper prints 1.84).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final

from grouptron.reporting.cells import OURS_MODELS, display_name, published_pair

MOST_LIKELY: Final = "ml"
"""One forecast per person: the most likely (Trajectron++, Grouptron) or the one a
deterministic model makes (Social-LSTM)."""
BEST_OF_20: Final = "best-of-20"
"""The lowest error of 20 sampled futures per person (ADE and FDE minimised independently)."""


@dataclass(frozen=True)
class PublishedRow:
    """One published row.

    Attributes:
        method: our model name where we have the model (``trajectron++``, ``grouptron``),
            else the method's name as printed.
        kind: the forecast scored: :data:`MOST_LIKELY` or :data:`BEST_OF_20`.
        cells: (FDE, ADE) by split or subset name; ``mean`` is the AVG column.
        source: where the numbers come from (paper and table), and how the Grouptron paper
            cites them where it differs.
    """

    method: str
    kind: str
    cells: Mapping[str, tuple[float, float]]
    source: str


SOCIAL_LSTM = PublishedRow(
    "Social-LSTM",
    MOST_LIKELY,
    {
        "eth": (2.35, 1.09),
        "hotel": (1.76, 0.79),
        "univ": (1.40, 0.67),
        "zara1": (1.00, 0.47),
        "zara2": (1.17, 0.56),
        "mean": (1.54, 0.72),
    },
    "Alahi et al., CVPR 2016, as evaluated by Gupta et al., CVPR 2018 (Social-GAN), Table 1 "
    "(S-LSTM: one deterministic forecast); cited so by the Grouptron paper's Table I",
)
SOCIAL_GAN = PublishedRow(
    "Social-GAN",
    BEST_OF_20,
    {
        "eth": (1.52, 0.81),
        "hotel": (1.61, 0.72),
        "univ": (1.26, 0.60),
        "zara1": (0.69, 0.34),
        "zara2": (0.84, 0.42),
        "mean": (1.18, 0.58),
    },
    "Gupta et al., CVPR 2018, Table 1 (SGAN-20VP-20: best of 20 samples); the Grouptron "
    "paper's Table I prints ZARA2 as 1.84/0.42, a misprint (its AVG 1.18 needs 0.84)",
)
SOPHIE = PublishedRow(
    "SoPhie",
    BEST_OF_20,
    {
        "eth": (1.43, 0.70),
        "hotel": (1.67, 0.76),
        "univ": (1.24, 0.54),
        "zara1": (0.63, 0.30),
        "zara2": (0.78, 0.38),
        "mean": (1.15, 0.54),
    },
    "Sadeghian et al., CVPR 2019, Table 1 (best of 20 samples); the Grouptron paper's Table I "
    "prints ZARA1 as FDE/ADE 0.63/0.34 (SoPhie's own ADE there is 0.30; the AVG 0.54 holds "
    "either way)",
)
TRAJECTRON = PublishedRow(
    "trajectron++",
    MOST_LIKELY,
    {
        "eth": (1.68, 0.71),
        "hotel": (0.46, 0.22),
        "univ": (1.07, 0.41),
        "zara1": (0.77, 0.30),
        "zara2": (0.59, 0.23),
        "mean": (0.91, 0.37),
    },
    "Salzmann et al., ECCV 2020 (most likely, without maps), as cited in the Grouptron "
    "paper's Table I",
)
GROUPTRON = PublishedRow(
    "grouptron",
    MOST_LIKELY,
    {
        "eth": (1.56, 0.70),
        "hotel": (0.46, 0.21),
        "univ": (0.97, 0.38),
        "zara1": (0.76, 0.30),
        "zara2": (0.56, 0.22),
        "mean": (0.86, 0.36),
    },
    "Zhou et al., ICRA 2022 (Grouptron), Table I (its predictions are the most likely ones)",
)
TRAJECTRON_DENSE = PublishedRow(
    "trajectron++",
    MOST_LIKELY,
    {
        "univ": (1.07, 0.41),
        "univ-40": (1.17, 0.436),
        "univ-45": (1.24, 0.46),
        "univ-50": (1.25, 0.47),
    },
    "Zhou et al., ICRA 2022 (Grouptron), Table II (Trajectron++ scored by the Grouptron authors)",
)
GROUPTRON_DENSE = PublishedRow(
    "grouptron",
    MOST_LIKELY,
    {
        "univ": (0.97, 0.38),
        "univ-40": (1.00, 0.39),
        "univ-45": (1.04, 0.40),
        "univ-50": (1.07, 0.42),
    },
    "Zhou et al., ICRA 2022 (Grouptron), Table II",
)

TRAJECTRON_BEST_OF_20 = PublishedRow(
    "trajectron++",
    BEST_OF_20,
    {
        "eth": (0.83, 0.39),
        "hotel": (0.21, 0.12),
        "univ": (0.44, 0.20),
        "zara1": (0.33, 0.15),
        "zara2": (0.25, 0.11),
        "mean": (0.41, 0.19),
    },
    "Salzmann et al., ECCV 2020, Table 1 (best of 20, without maps; the model that outputs "
    "velocities, per its repository's eccv2020 results notebook); the Grouptron paper prints "
    "no best-of-20 row, of Trajectron++ or of its own",
)
SOCIAL_STGCNN = PublishedRow(
    "Social-STGCNN",
    BEST_OF_20,
    {
        "eth": (1.11, 0.64),
        "hotel": (0.85, 0.49),
        "univ": (0.79, 0.44),
        "zara1": (0.53, 0.34),
        "zara2": (0.48, 0.30),
        "mean": (0.75, 0.44),
    },
    "Mohamed et al., CVPR 2020, Table 1 (best of 20; each person's lowest ADE and FDE taken "
    "on their own; only people present in all 20 steps of a window are in its graph)",
)
TRANSFORMER_BEST_OF_20 = PublishedRow(
    "Transformer TF_q",  # not our small Transformer: the paper's, far larger
    BEST_OF_20,
    {
        "eth": (1.12, 0.61),
        "hotel": (0.30, 0.18),
        "univ": (0.65, 0.35),
        "zara1": (0.38, 0.22),
        "zara2": (0.32, 0.17),
        "mean": (0.55, 0.31),
    },
    "Giuliari et al., ICPR 2020, TF_q (a 512-wide, 6-layer Transformer over quantised "
    "displacements, best of 20), as quoted by later comparisons: the paper's own table was "
    "not re-read for this row, and its one-forecast TF row is left out for that reason",
)

TABLE_I_ROWS: Final = (SOCIAL_LSTM, SOCIAL_GAN, SOPHIE, TRAJECTRON, GROUPTRON)
"""The rows of the Grouptron paper's Table I (ETH/UCY test sets, leave one location out), in
its order."""
TABLE_II_ROWS: Final = (TRAJECTRON_DENSE, GROUPTRON_DENSE)
"""The rows of its Table II: the UNIV test set and its dense subsets UNIV-N."""
BENCHMARK_ROWS: Final = (
    *TABLE_I_ROWS,
    TRAJECTRON_BEST_OF_20,
    SOCIAL_STGCNN,
    TRANSFORMER_BEST_OF_20,
)
"""Every published ETH/UCY row the report prints: Table I's, and the best-of-20 rows of
Trajectron++ and of the learned baselines' papers beside ours."""


def of_kind(rows: tuple[PublishedRow, ...], kind: str) -> dict[str, dict[str, tuple[float, float]]]:
    """The cells of the rows of one forecast kind, by method, in order."""
    return {row.method: dict(row.cells) for row in rows if row.kind == kind}


TABLE_I: Final = of_kind(TABLE_I_ROWS, MOST_LIKELY)
"""Table I's most likely rows: what our most likely rows are compared with."""
TABLE_II: Final = of_kind(TABLE_II_ROWS, MOST_LIKELY)
"""Table II's (all most likely)."""


def _name(method: str) -> str:
    """A published row's method as the tables print it (ours by their display names)."""
    return display_name(method) if method in OURS_MODELS else method


def published_lines(
    rows: tuple[PublishedRow, ...], kind: str, columns: tuple[str, ...]
) -> list[list[str]]:
    """Table lines (method, ``published``, a cell per column, ``-`` where the paper has none)
    of the rows of one kind."""
    return [
        [
            _name(row.method),
            "published",
            *(published_pair(row.cells[c]) if c in row.cells else "-" for c in columns),
        ]
        for row in rows
        if row.kind == kind
    ]


def sources_note(rows: tuple[PublishedRow, ...], kind: str) -> list[str]:
    """Lines naming the source of each published row of one kind (none without such rows)."""
    found = [row for row in rows if row.kind == kind]
    if not found:
        return []
    return ["", "Published rows:", *(f"- {_name(row.method)}: {row.source}." for row in found)]
