"""The report's target lines on hand-made evidence: each says met only when it is."""

from __future__ import annotations

from grouptron.evaluation.uncertainty import Interval
from grouptron.reporting.stats import PairedDifference, SeedSpread
from grouptron.reporting.targets import target_checks

COLUMNS = ("univ", "univ-40", "univ-45", "univ-50")


def _paired(
    high: float, derivatives: str = "backward", variant: str = "grouptron-robust"
) -> list[PairedDifference]:
    """variant - trajectron++ on univ and its UNIV-N, with intervals up to ``high``."""
    return [
        PairedDifference(
            derivatives,
            "ml",
            variant,
            "trajectron++",
            column,
            100,
            Interval(high - 0.05, high - 0.1, high),
            Interval(-0.01, -0.02, 0.0),
        )
        for column in COLUMNS
    ]


def _seeds(worst: float) -> list[SeedSpread]:
    name = "grouptron-robust - trajectron++"
    return [
        SeedSpread(name, "backward", c, (0, 1, 2), (-0.1, -0.05, worst), (0, 0, 0)) for c in COLUMNS
    ]


def _seeds_with_intervals(worst_high: float) -> list[SeedSpread]:
    """Every seed's mean below zero; the last seed's interval reaches ``worst_high``."""
    name = "grouptron-robust - trajectron++"
    intervals = ((-0.15, -0.05), (-0.1, -0.01), (-0.06, worst_high))
    return [
        SeedSpread(name, "backward", c, (0, 1, 2), (-0.1, -0.05, -0.02), (0, 0, 0), intervals)
        for c in COLUMNS
    ]


def _variant_line(checks: list[str]) -> str:
    (line,) = [c for c in checks if "paired 95% intervals below zero" in c]
    return line


def test_the_variant_target_needs_every_interval_and_every_seed_below_zero() -> None:
    met = _variant_line(target_checks({}, ("backward",), _paired(-0.01), _seeds(-0.02)))
    assert ": met (" in met and "difference (seeds 0, 1, 2), highest: UNIV -0.020" in met
    touching = _variant_line(target_checks({}, ("backward",), _paired(0.001), _seeds(-0.02)))
    assert "NOT met" in touching
    one_seed_worse = _variant_line(target_checks({}, ("backward",), _paired(-0.01), _seeds(0.03)))
    assert "NOT met" in one_seed_worse and "highest: UNIV +0.030" in one_seed_worse
    without_seeds = _variant_line(target_checks({}, ("backward",), _paired(-0.01)))
    assert ": met (" in without_seeds and "each seed" not in without_seeds


def test_no_variant_line_without_every_column_or_for_another_protocol() -> None:
    assert not any("paired 95%" in c for c in target_checks({}, ("backward",), _paired(-0.01)[:3]))
    central = target_checks({}, ("backward",), _paired(-0.01, "central"))
    assert not any("paired 95%" in c for c in central)


def test_each_named_group_variant_gets_its_own_line() -> None:
    evidence = _paired(-0.01) + _paired(0.02, variant="grouptron-robust-residual")
    lines = [c for c in target_checks({}, ("backward",), evidence) if "paired 95%" in c]
    assert len(lines) == 2
    assert lines[0].startswith("- Grouptron (robust) ML FDE") and ": met (" in lines[0]
    assert lines[1].startswith("- Grouptron (robust, residual) ML FDE") and "NOT met" in lines[1]


def test_with_per_seed_intervals_every_seed_interval_must_be_below_zero() -> None:
    met = _variant_line(
        target_checks({}, ("backward",), _paired(-0.01), _seeds_with_intervals(-0.001))
    )
    assert ": met (" in met and "interval (seeds 0, 1, 2), highest upper end: UNIV -0.001" in met
    # Seed 2 is lower on average, but its interval reaches above zero.
    crossing = _variant_line(
        target_checks({}, ("backward",), _paired(-0.01), _seeds_with_intervals(0.02))
    )
    assert "NOT met" in crossing and "upper end: UNIV +0.020" in crossing


def _causal_evidence(model_avg_fde: float) -> tuple[dict, list[PairedDifference]]:
    """A model scored causally on all five splits (each 0.01 m below constant velocity) and
    the averages of both."""
    from grouptron.constants import SPLITS
    from grouptron.evaluation.results import MEAN_ROW, EvaluationResult

    rows = {
        (model, "backward", MEAN_ROW, "ml"): EvaluationResult(
            MEAN_ROW, model, None, 5, 0.5, fde, "ml", derivatives="backward"
        )
        for model, fde in (("trajectron++", model_avg_fde), ("constant-velocity", 1.2))
    }
    paired = [
        PairedDifference(
            "backward",
            "ml",
            "trajectron++",
            "constant-velocity",
            column,
            100,
            Interval(-0.01, -0.02, 0.0),
            Interval(-0.01, -0.02, 0.0),
        )
        for column in (*SPLITS, MEAN_ROW)
    ]
    return rows, paired


def test_the_causal_average_must_be_ten_percent_below_constant_velocity() -> None:
    def average_line(model_avg_fde: float) -> str:
        rows, paired = _causal_evidence(model_avg_fde)
        (line,) = [c for c in target_checks(rows, ("backward",), paired) if "on AVG" in c]
        return line

    assert ": met (1.080 vs 1.200 m, 10.0% below" in average_line(1.08)
    assert ": NOT met (1.100 vs 1.200 m, 8.3% below" in average_line(1.1)
    assert "paired difference -0.010 [-0.020, +0.000]" in average_line(1.1)
    # Every split at or below constant velocity is its own line.
    rows, paired = _causal_evidence(1.1)
    assert any("on every split: met" in c for c in target_checks(rows, ("backward",), paired))
