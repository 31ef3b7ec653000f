"""A metric is one function and one registry line: it then appears in ``evaluate``'s JSON and
table and in the dataset report, through the score cache, with no other edit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.config import DataConfig
from grouptron.data.datasets.custom import load_dataset_part, read_dataset
from grouptron.evaluation import metrics
from grouptron.evaluation.evaluate import constant_velocity_scores
from tests.conftest import synthetic_recording


def miss_2m(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """1 where the final position is more than 2 m off, else 0: (..., H, 2) -> (...)."""
    return (metrics.fde(pred, truth) > 2.0).astype(np.float64)


def _dataset(folder: Path) -> Path:
    for seed in (1, 2, 3):
        synthetic_recording(folder / f"walk{seed}.txt", seed, pedestrians=10, steps=50)
    described = folder / "walks.toml"
    described.write_text(
        'name = "walks"\n[parts]\ntrain = "walk1.txt"\nval = "walk2.txt"\ntest = "walk3.txt"\n'
    )
    return described


@pytest.mark.slow
def test_a_registered_metric_reaches_the_evaluation_json_and_the_report(
    tiny_checkpoints: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    described = _dataset(tmp_path)
    out = tmp_path / "runs" / "tuned"
    start = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    train = ["train", "--dataset", str(described), "--init-from", start, "--epochs", "1"]
    assert main([*train, "--out", str(out), "--quiet", "--precision", "fp32"]) == 0
    report = ["report", "--dataset", str(described), "--checkpoints", str(tmp_path / "runs")]
    report += ["--mode", "ml,best-of-20", "--quiet"]
    assert main(report) == 0  # scored and cached before the metric exists
    capsys.readouterr()

    monkeypatch.setitem(metrics.METRICS, "miss_2m", metrics.Metric("miss_2m", "miss >2 m", miss_2m))
    evaluate = [
        "evaluate",
        "--dataset",
        str(described),
        "--checkpoint",
        str(out / "best.safetensors"),
    ]
    assert main([*evaluate, "--format", "json"]) == 0
    model_row, baseline_row = json.loads(capsys.readouterr().out)["results"]
    samples = load_dataset_part(read_dataset(described), "test", DataConfig(derivatives="backward"))
    baseline = constant_velocity_scores(samples.samples, 12)
    assert baseline_row["miss_2m"] == pytest.approx(float((baseline.fde > 2.0).mean()))
    assert 0.0 <= model_row["miss_2m"] <= 1.0
    assert main(evaluate) == 0
    assert "miss >2 m" in capsys.readouterr().out  # a column of the table

    assert main([*report, "--format", "json"]) == 0  # the cached scores lack it: scored again
    rows = json.loads(capsys.readouterr().out)["results"]
    assert all("miss_2m" in r and "miss_2m_ci" in r for r in rows)
    cv = next(r for r in rows if r["model"] == "constant-velocity")
    assert cv["miss_2m"] == pytest.approx(baseline_row["miss_2m"])
    assert cv["miss_2m_ci"][0] <= cv["miss_2m"] <= cv["miss_2m_ci"][1]
    assert main(report) == 0
    table = capsys.readouterr().out
    assert "miss >2 m [95% interval]" in table and table.count("| grouptron |") == 2
