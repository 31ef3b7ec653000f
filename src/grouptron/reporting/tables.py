"""The report's rows as Markdown: the paper's Tables I and II with our numbers beside the
published ones, then best-of-20, KDE NLL, the targets and the checkpoints used.

Cells print ADE/FDE (the field's order; the paper prints FDE/ADE). "Δ" cells are (ours -
published) / published in percent for ADE / FDE; negative is better.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from grouptron.constants import CONSTANT_VELOCITY, DEFAULT_CHECKPOINT
from grouptron.evaluation.results import EvaluationResult
from grouptron.evaluation.uncertainty import Interval, seed_spread
from grouptron.model.factory import GROUP_MODELS
from grouptron.point_forecast import PointForecast, best_of_samples, is_point_forecast
from grouptron.reporting.cells import (
    DISPLAY,
    OURS_MODELS,
    PRESENT_COLUMNS,
    TABLE_I_COLUMNS,
    TABLE_II_COLUMNS,
    Key,
    ade_fde,
    display_name,
    index_rows,
    markdown_table,
    ours_models,
    percent_change,
    published_pair,
)
from grouptron.reporting.diagnostics import diagnostics_markdown
from grouptron.reporting.metric_tables import metric_tables
from grouptron.reporting.out_of_domain import out_of_domain_markdown
from grouptron.reporting.published import (
    BENCHMARK_ROWS,
    BEST_OF_20,
    MOST_LIKELY,
    TABLE_I,
    TABLE_I_ROWS,
    TABLE_II,
    published_lines,
    sources_note,
)
from grouptron.reporting.stats import PairedDifference, Report, SeedSpread
from grouptron.reporting.targets import target_checks

SEEDS_NOTE = (
    "Most likely scores of every seed run; a group model - Trajectron++ compares runs of the "
    "same seed on the same samples, each seed with its paired 95% interval over resampled "
    "time steps (`*`: the interval excludes zero)."
)


def _versus_lines(
    rows: dict[Key, EvaluationResult], columns: Sequence[str], schemes: Sequence[str]
) -> list[list[str]]:
    """Each group model against our Trajectron++, in percent, per derivatives."""
    lines = []
    for model in GROUP_MODELS:
        for derivatives in schemes:
            pairs = [
                (
                    rows.get((model, derivatives, c, "ml")),
                    rows.get(("trajectron++", derivatives, c, "ml")),
                )
                for c in columns
            ]
            if any(g and t for g, t in pairs):
                cells = [
                    f"{percent_change(g.ade, t.ade)} / {percent_change(g.fde, t.fde)}"
                    if g and t
                    else "-"
                    for g, t in pairs
                ]
                name = f"{display_name(model)} vs Trajectron++"
                lines.append([name, f"Δ ours, {derivatives}", *cells])
    return lines


# Table I as the paper lays it out, row group after row group (published, ours, the seed
# lines, the baseline, the differences): one sequence read top to bottom, like the table.
def _ml_table(
    rows: dict[Key, EvaluationResult],
    columns: Sequence[str],
    published: dict[str, dict[str, tuple[float, float]]],
    schemes: Sequence[str],
    seeds: Sequence[SeedSpread] = (),
) -> list[str]:
    """Published rows, our rows per derivatives (each with its seeds' spread where it has
    several), Δ to published (central) and Grouptron vs ours."""
    lines: list[list[str]] = []

    def ours(model: str, derivatives: str, column: str) -> EvaluationResult | None:
        return rows.get((model, derivatives, column, "ml"))

    for method, values in published.items():
        if method in OURS_MODELS:
            continue
        lines.append([method, "published", *(published_pair(values[c]) for c in columns)])
    for model in ours_models(rows):
        if model in published:
            values = published[model]
            lines.append(
                [display_name(model), "published", *(published_pair(values[c]) for c in columns)]
            )
        for derivatives in schemes:
            cells = [ours(model, derivatives, c) for c in columns]
            if not any(cells):
                continue
            lines.append(
                [
                    display_name(model),
                    f"ours, {derivatives}",
                    *(ade_fde(r.ade, r.fde) if r else "-" for r in cells),
                ]
            )
            lines += _seed_line(seeds, model, derivatives, columns)
            if derivatives == "central" and model in published:
                lines.append(
                    [
                        "",
                        "Δ ours vs published",
                        *(
                            f"{percent_change(r.ade, published[model][c][1])} / "
                            f"{percent_change(r.fde, published[model][c][0])}"
                            if r
                            else "-"
                            for r, c in zip(cells, columns, strict=True)
                        ),
                    ]
                )
    lines += _versus_lines(rows, columns, schemes)
    cv = [rows.get((CONSTANT_VELOCITY, schemes[0], c, "ml")) for c in columns]
    if any(cv):
        lines.append(
            [
                display_name(CONSTANT_VELOCITY),
                "ours",
                *(ade_fde(r.ade, r.fde) if r else "-" for r in cv),
            ]
        )
    return markdown_table(["method", "source", *(display_name(c) for c in columns)], lines)


def _seed_line(
    seeds: Sequence[SeedSpread], model: str, derivatives: str, columns: Sequence[str]
) -> list[list[str]]:
    """The line under a model's row where it has several seeds: per column, FDE mean ± sd
    over the seeds and, in brackets, the worst seed's FDE (the row is the run of the lowest seed
    number)."""
    found = {s.column: s for s in seeds if (s.model, s.derivatives) == (model, derivatives)}
    spreads = [found[c] for c in columns if c in found]
    if not spreads:
        return []
    listed = {s.seeds for s in spreads}
    named = f"seeds {', '.join(map(str, spreads[0].seeds))}" if len(listed) == 1 else "seeds"
    cells = []
    for column in columns:
        spread = found.get(column)
        if spread is None:
            cells.append("-")
            continue
        mean, sd = seed_spread(spread.fde)
        cells.append(f"{mean:.3f} ± {sd:.3f} ({max(spread.fde):.3f})")
    return [["", f"{named}: FDE mean ± sd (worst)", *cells]]


def _column_of(key: Key) -> str:
    return key[2]


def _mode_table(
    rows: dict[Key, EvaluationResult],
    columns: Sequence[str],
    mode: str,
    schemes: Sequence[str],
    *,
    with_baseline: bool = False,
) -> list[str]:
    """One line per (model, derivatives): ADE/FDE, or the NLL in nats for ``nll``; first the
    published rows of the mode's kind (best-of-20: Table I's)."""
    lines = published_lines(BENCHMARK_ROWS, mode, tuple(columns)) if mode == BEST_OF_20 else []
    models = (*ours_models(rows), CONSTANT_VELOCITY) if with_baseline else ours_models(rows)
    for derivatives in schemes:
        for model in models:
            cells = [rows.get((model, derivatives, c, mode)) for c in columns]
            if not any(cells):
                continue
            if mode == "nll":
                text = [
                    f"{r.nll:.3f} ({r.samples})" if r and r.nll is not None else "-" for r in cells
                ]
            else:
                text = [ade_fde(r.ade, r.fde) if r else "-" for r in cells]
            lines.append([display_name(model), derivatives, *text])
    if not lines:
        return []
    return markdown_table(["model", "derivatives", *(display_name(c) for c in columns)], lines)


def _ci(row: EvaluationResult | None) -> str:
    if row is None or row.fde_ci is None:
        return "-"
    return f"{row.fde:.3f} [{row.fde_ci[0]:.3f}, {row.fde_ci[1]:.3f}]"


def interval_table(
    rows: dict[Key, EvaluationResult], columns: Sequence[str], schemes: Sequence[str]
) -> list[str]:
    """ML FDE with its 95% interval (time steps resampled) per model, derivatives and column."""
    lines = []
    for derivatives in schemes:
        for model in (*ours_models(rows), CONSTANT_VELOCITY):
            cells = [rows.get((model, derivatives, c, "ml")) for c in columns]
            if any(cells):
                lines.append([display_name(model), derivatives, *(_ci(r) for r in cells)])
    return (
        markdown_table(["model", "derivatives", *(display_name(c) for c in columns)], lines)
        if lines
        else []
    )


def paired_table(paired: Sequence[PairedDifference], columns: Sequence[str]) -> list[str]:
    """Mean FDE differences (model - baseline, same samples) with 95% intervals; a * marks an
    interval that excludes zero."""
    lines = [
        [
            f"{display_name(model)} - {display_name(baseline)}",
            f"{derivatives}, {mode}",
            *(p.fde.signed_text() if p else "-" for p in found),
        ]
        for (derivatives, mode, model, baseline), found in _rows_of(
            paired, columns, lambda p: (p.derivatives, p.mode, p.model, p.baseline)
        )
    ]
    return markdown_table(
        ["difference", "derivatives, mode", *(display_name(c) for c in columns)], lines
    )


def to_best_table(to_best: Sequence[PairedDifference], columns: Sequence[str]) -> list[str]:
    """Every model's mean FDE minus the best one's of each column (``best`` there), with
    95% intervals on the same samples; a * marks an interval that excludes zero."""

    def cell(p: PairedDifference | None) -> str:
        return "-" if p is None else "**best**" if p.model == p.baseline else p.fde.signed_text()

    rows = _rows_of(to_best, columns, lambda p: (p.derivatives, p.mode, p.model))
    lines = [[display_name(m), f"{d}, {mode}", *map(cell, found)] for (d, mode, m), found in rows]
    return markdown_table(
        ["model", "derivatives, mode", *(display_name(c) for c in columns)], lines
    )


def _rows_of(
    diffs: Sequence[PairedDifference],
    columns: Sequence[str],
    row: Callable[[PairedDifference], tuple[str, ...]],
) -> list[tuple[tuple[str, ...], list[PairedDifference | None]]]:
    """The table rows ``row`` names, in order of first appearance, each with its difference in
    every column (None where it has none)."""
    index = {(row(p), p.column): p for p in diffs}
    return [(key, [index.get((key, c)) for c in columns]) for key in dict.fromkeys(map(row, diffs))]


def seed_table(seeds: Sequence[SeedSpread]) -> list[str]:
    """ML FDE and ADE mean +- sd over seed runs."""
    lines = []
    for s in seeds:
        (fde, fde_sd), (ade, ade_sd) = seed_spread(s.fde), seed_spread(s.ade)
        name = " - ".join(display_name(part) for part in s.model.split(" - "))
        lines.append(
            [
                name,
                s.derivatives,
                display_name(s.column),
                ", ".join(str(seed) for seed in s.seeds),
                f"{fde:.3f} ± {fde_sd:.3f}",
                f"{ade:.3f} ± {ade_sd:.3f}",
                ", ".join(_per_seed(s)),
            ]
        )
    header = ["model", "derivatives", "test set", "seeds", "FDE mean ± sd", "ADE mean ± sd"]
    return markdown_table([*header, "FDE per seed"], lines)


def _per_seed(spread: SeedSpread) -> list[str]:
    """Each seed's FDE; a paired difference's with its 95% interval and ``*`` where that
    interval excludes zero."""
    if not spread.fde_intervals:
        return [f"{v:.3f}" for v in spread.fde]
    return [
        Interval(v, low, high).signed_text()
        for v, (low, high) in zip(spread.fde, spread.fde_intervals, strict=True)
    ]


def _paper_tables(
    rows: dict[Key, EvaluationResult], schemes: Sequence[str], seeds: Sequence[SeedSpread] = ()
) -> list[str]:
    """Tables I and II (the paper's UNIV-N), then UNIV-N counting pedestrians present."""
    out = [
        "## Table I: ETH/UCY, most likely prediction",
        "",
        *_ml_table(rows, TABLE_I_COLUMNS, TABLE_I, schemes, seeds),
        *sources_note(TABLE_I_ROWS, MOST_LIKELY),
        "",
        "The paper's Table I also prints Social-GAN and SoPhie: their numbers are the best of 20",
        "sampled futures per person, not one forecast, so they are printed with the best-of-20",
        "scores (`--mode best-of-20`).",
        "",
        "## Table II: dense UNIV subsets, most likely",
        "",
        "UNIV-N as the paper counted it: the univ test samples at time steps with N or more",
        "predicted agents (test samples). Scoring the public Trajectron++ univ weights this way",
        "reproduces the paper's Trajectron++ row to within 0.007 m.",
        "",
        *_ml_table(rows, TABLE_II_COLUMNS, TABLE_II, schemes, seeds),
    ]
    present = [c for c in PRESENT_COLUMNS if any(_column_of(k) == c for k in rows)]
    if present:
        out += [
            "",
            "### UNIV-N counting pedestrians present",
            "",
            "The same, at time steps with N or more pedestrians *present* (observed at t,",
            "whatever their history or future): many more samples; not the paper's definition.",
            "",
            *_mode_table(rows, ("univ", *present), "ml", schemes, with_baseline=True),
        ]
    return out


def _certainty_sections(
    report: Report, rows: dict[Key, EvaluationResult], schemes: Sequence[str]
) -> list[str]:
    """Intervals of every score, paired differences and the seed spread."""
    columns = (*TABLE_I_COLUMNS, *TABLE_II_COLUMNS[1:])
    out = [
        "## How sure: 95% intervals",
        "",
        "Most likely FDE (m) with its 95% bootstrap interval; the bootstrap resamples whole",
        "time steps (samples of one step are not independent), 2000 replicates; AVG resamples",
        "each split and averages.",
        "",
        *interval_table(rows, columns, schemes),
    ]
    if report.paired:
        out += [
            "",
            "### Paired differences",
            "",
            "Mean FDE difference (m) on the same test samples, model minus baseline, with its",
            "95% interval over resampled time steps; negative: the model is better; `*`: the",
            "interval excludes zero.",
            "",
            *paired_table(report.paired, columns),
        ]
    if report.to_best:
        out += [
            "",
            "### Every model against the best",
            "",
            "Mean FDE (m) minus that of the column's best model (lowest mean FDE) on the same",
            "test samples, with its 95% interval over resampled time steps; one forecast",
            "(constant velocity's among them) and the best of 20 (the models that sample);",
            "`*`: the interval excludes zero.",
            "",
            *to_best_table(report.to_best, columns),
        ]
    if report.seeds:
        out += ["", "## Seeds", "", SEEDS_NOTE, ""]
        out += seed_table(report.seeds)
    return out


def _other_modes(
    rows: dict[Key, EvaluationResult], modes: Sequence[str | None], schemes: Sequence[str]
) -> list[str]:
    titles = {
        "ml-argmax": "Most likely latent value only (decode the argmax z, follow its means)",
        "mean": "Mean trajectory (every latent value's, weighted by p(z|x))",
        "ml-top10": "Most likely of the 10 most probable latent values (mixture mode per step)",
        "best-of-20": "Best of 20 samples (minADE/minFDE)",
        "nll": "KDE NLL in nats (Scott's bandwidth; 2000 futures per sample; "
        "in brackets: samples scored)",
    }
    for mode in modes:  # ml-topK and best-of-K for other K, in the order asked
        top = PointForecast.parse(mode).top if mode and is_point_forecast(mode) else None
        if mode and top and top > 1 and mode not in titles:
            titles[mode] = f"Most likely of the {top} most probable latent values"
        best_of = best_of_samples(mode) if mode else None
        if mode and best_of and mode not in titles:
            titles[mode] = f"Best of {best_of} samples (minADE/minFDE)"
    out = []
    for mode, title in titles.items():
        if mode in modes:
            table = _mode_table(rows, (*TABLE_I_COLUMNS, *TABLE_II_COLUMNS[1:]), mode, schemes)
            out += ["", f"## {title}", "", *table]
            out += sources_note(BENCHMARK_ROWS, mode)  # the published rows of its kind
    return out


def report_markdown(report: Report, schemes: Sequence[str], command: str) -> str:
    """The whole report as a Markdown document."""
    results = report.rows
    rows = index_rows(results)
    modes = list(dict.fromkeys(r.mode for r in results if r.model != CONSTANT_VELOCITY))
    out = [
        "# Results",
        "",
        f"Generated by `{command}` from the checkpoints listed at the end; do not edit by hand.",
        "Cells are ADE/FDE in metres on the test sets (leave one location out), the field's",
        "order (the Grouptron paper prints FDE/ADE). *published* rows are copied from the",
        "papers (central derivatives), each in the table of the forecast it scores, its source",
        "under that table. *ours* rows are measured, each from one training run: the lowest",
        "seed number found (seed 0 where there is one, as for every shipped checkpoint); where",
        "a model has more seeds, the line under its row gives the FDE mean ± sd over them and,",
        "in brackets, the worst seed's. Δ is the difference in percent (negative: lower error).",
        "Derivatives: `central` ones are the papers' inputs (the velocity at the last observed",
        "step uses the next, unobserved position); `backward` ones are causal.",
        "",
        f"The shipped default model, `{DEFAULT_CHECKPOINT}`, trained on every ETH/UCY",
        "recording (the test sets included) and on crowds from elsewhere, so no benchmark table",
        "has a row of it; it is scored on recordings from elsewhere (the out-of-domain section",
        'where the report has one, and benchmarks/RESULTS.md, "A deployment model").',
        "",
        *_paper_tables(rows, schemes, report.seeds),
        "",
        *_certainty_sections(report, rows, schemes),
        *_other_modes(rows, modes, schemes),
        *metric_tables(rows, modes, schemes),
        *diagnostics_markdown(report.density, report.ablations, DISPLAY),
        *out_of_domain_markdown(report.out_of_domain),
    ]
    checks = target_checks(rows, schemes, report.paired, report.seeds)
    if checks:
        out += ["", "## Targets", "", *checks]
    whole = [r for r in results if r.checkpoint and not r.subset and r.mode == "ml"]
    used = sorted({(r.checkpoint, r.samples) for r in whole})
    if used:
        out += ["", "## Checkpoints", ""]
        out += markdown_table(["checkpoint", "test samples"], [[f"`{p}`", str(n)] for p, n in used])
    return "\n".join(out) + "\n"
