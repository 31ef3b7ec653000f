"""The evaluation papers report: best-of-K for any K, a miss rate at any threshold, the error
of every forecast step and a 95% interval for every mean, from the command line and from
Python (``evaluate --mode best-of-5,best-of-20 --metrics miss-rate-2m``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import score_samples
from grouptron.evaluation.results import EvaluationResult
from grouptron.point_forecast import best_of_samples, is_evaluation_mode
from grouptron.workflows.evaluate import Benchmark, EvaluationOptions, evaluate
from tests.helpers.data import eth_test_samples

H = 12
PAPERS = ("best-of-5", "best-of-20")


@pytest.fixture(scope="module")
def checkpoint(tiny_checkpoints: Path) -> str:
    return str(tiny_checkpoints / "trajectron++-eth-central" / "best.safetensors")


def test_best_of_k_is_a_mode_for_every_k_by_its_one_name() -> None:
    assert [best_of_samples(m) for m in ("best-of-1", "best-of-5", "best-of-20")] == [1, 5, 20]
    assert all(is_evaluation_mode(m) for m in ("best-of-1", "best-of-7", "best-of-100"))
    for bad in ("best-of-0", "best-of-05", "best-of-", "best-of-x", "best-5"):
        assert not is_evaluation_mode(bad) and best_of_samples(bad) is None


def test_miss_rate_is_a_metric_of_any_threshold_by_name() -> None:
    rate = metrics.resolve_metric("miss-rate-2m")
    assert (rate.name, rate.label) == ("miss-rate-2m", "MR 2m")
    assert metrics.resolve_metric("miss-rate-0.5m").name == "miss-rate-0.5m"
    assert metrics.resolve_metric("miss-rate-2.0m") == rate  # one metric, one name
    truth = np.zeros((3, H, 2))
    pred = np.zeros((3, H, 2))
    pred[:, -1, 0] = [1.0, 2.0, 3.0]  # only the final error counts
    pred[0, 5, 0] = 9.0
    assert rate.score(pred, truth).tolist() == [0.0, 0.0, 1.0]
    for bad in ("miss-rate-0m", "miss-rate-m", "miss-rate-2", "nosuch"):
        with pytest.raises(GrouptronError):
            metrics.resolve_metric(bad)


def test_best_of_k_miss_rate_and_step_errors_per_sample(
    tiny_checkpoints: Path, synthetic_data_dir: Path
) -> None:
    """best-of-K's miss is the minimum final error's (as papers score it), its last step's
    error is minFDE; a point forecast's step errors average to its ADE; each mode draws from
    its own seeded generator, so it scores the same whatever is asked with it."""
    model, config, samples = eth_test_samples(tiny_checkpoints, synthetic_data_dir)
    with metrics.scoring(("miss-rate-2m",)):
        five, ml, twenty = score_samples(model, config, samples, ("best-of-5", "ml", *PAPERS[1:]))
        (alone,) = score_samples(model, config, samples, ("best-of-5",))
    assert "miss-rate-2m" not in metrics.METRICS  # asked for one evaluation, then gone
    for scores in (five, twenty):
        missed = scores.values["miss-rate-2m"]
        np.testing.assert_array_equal(missed, (scores.fde > 2.0).astype(float))
        steps = scores.per_step[metrics.DISPLACEMENT]
        assert steps.shape == (len(samples), H)
        np.testing.assert_allclose(steps[:, -1], scores.fde)
        assert metrics.DISPLACEMENT not in scores.values
    np.testing.assert_allclose(ml.per_step[metrics.DISPLACEMENT].mean(axis=1), ml.ade)
    np.testing.assert_allclose(alone.fde, five.fde, rtol=1e-5)
    assert np.mean(twenty.fde) <= np.mean(five.fde) + 0.05  # 20 draws rarely do worse


def _has_intervals(row: EvaluationResult) -> None:
    """Every mean of the row lies in its 95% interval, per step too."""
    assert row.ade_ci is not None and row.ade_ci[0] <= row.ade <= row.ade_ci[1]
    assert row.fde_ci is not None and row.fde_ci[0] <= row.fde <= row.fde_ci[1]
    for name, value in row.metrics.items():
        low, high = row.metrics_ci[name]
        assert low <= value <= high
    for name, values in row.per_step.items():
        assert len(row.per_step_ci[name]) == len(values) == H
        assert all(lo <= v <= hi for v, (lo, hi) in zip(values, row.per_step_ci[name], strict=True))


@pytest.mark.slow
def test_evaluate_from_python(checkpoint: str, synthetic_data_dir: Path) -> None:
    source = Benchmark(splits=("eth",), data_dir=synthetic_data_dir)
    options = EvaluationOptions(metrics=("miss-rate-2m",))
    rows = evaluate(source, checkpoint, modes=PAPERS, options=options)
    assert [(r.model, r.mode) for r in rows] == [
        ("trajectron++", "best-of-5"),
        ("trajectron++", "best-of-20"),
        ("constant-velocity", None),
    ]
    for row in rows:
        assert 0.0 <= row.metrics["miss-rate-2m"] <= 1.0
        assert row.per_step["displacement"][-1] == pytest.approx(row.fde)
        _has_intervals(row)
    assert "miss-rate-2m" not in metrics.METRICS
    (plain, _) = evaluate(source, checkpoint, ("best-of-5",))  # the metric was this call's
    assert "miss-rate-2m" not in plain.metrics
    assert plain.fde == rows[0].fde  # seeded per mode
    with pytest.raises(GrouptronError, match="needs a --checkpoint"):
        evaluate(source, None, ("best-of-7",))
    with pytest.raises(GrouptronError, match="unknown metric"):
        evaluate(source, checkpoint, ("ml",), EvaluationOptions(metrics=("nosuch",)))


@pytest.mark.slow
def test_evaluate_from_the_command_line(
    checkpoint: str, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--checkpoint", checkpoint, "--split", "eth"]
    argv += ["--data-dir", str(synthetic_data_dir), "--quiet"]
    argv += ["--mode", "best-of-5,best-of-20", "--metrics", "miss-rate-2m"]
    assert main([*argv, "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert [r.get("mode") for r in rows] == ["best-of-5", "best-of-20", None]
    for row in rows:
        for name in ("ade", "fde", "miss-rate-2m"):
            low, high = row[f"{name}_ci"]
            assert low <= row[name] <= high
        assert len(row["displacement_per_step"]) == len(row["displacement_per_step_ci"]) == H
    assert main(argv) == 0
    header = capsys.readouterr().out.splitlines()[0]
    for column in ("MR 2m", "DE m @4", "DE m @8", "DE m @12", "FDE 95% interval"):
        assert column in header
    assert main(["evaluate", "--model", "constant-velocity", *argv[3:]]) == 2
    assert "needs a --checkpoint" in capsys.readouterr().err
    assert main([*argv[:-1], "miss-rate-0m"]) == 2
    assert "above 0 m" in capsys.readouterr().err
