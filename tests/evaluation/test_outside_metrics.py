"""Metrics from outside the package, without a wrapper script: ``--metrics module:name`` (a
function or a ``Metric`` of a module in the current folder or on the path) or an installed
package's ``grouptron.metrics`` entry point, in ``evaluate``'s and ``report``'s output."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.evaluation import metrics

MODULE = '''
import numpy as np

from grouptron.evaluation.metrics import Metric, fde


def lateral(pred, truth):
    """Mean absolute error across y over the horizon: (..., H, 2) -> (...)."""
    return np.abs(pred[..., 1] - truth[..., 1]).mean(axis=-1)


FAR = Metric("far-miss", "miss >0.5 m", lambda pred, truth: (fde(pred, truth) > 0.5) * 1.0)
'''


@pytest.fixture
def outside(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A module of metrics in a folder of its own, on the path, and a package's metadata there
    offering one of them as an entry point."""
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "outside_metrics.py").write_text(MODULE)
    info = folder / "outside_pkg-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: outside-pkg\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[grouptron.metrics]\nsideways = outside_metrics:lateral\n"
    )
    monkeypatch.syspath_prepend(str(folder))
    return folder


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> list[dict[str, object]]:
    capsys.readouterr()
    assert main([*argv, "--format", "json"]) == 0
    rows: list[dict[str, object]] = json.loads(capsys.readouterr().out)["results"]
    return rows


def test_outside_metrics_resolve_by_module_name_and_entry_point(
    outside: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    lateral = metrics.resolve_metric("outside_metrics:lateral")
    assert (lateral.name, lateral.label) == ("lateral", "lateral")
    assert metrics.resolve_metric("outside_metrics:FAR").label == "miss >0.5 m"
    assert metrics.resolve_metric("sideways").name == "sideways"
    truth, pred = np.zeros((2, 12, 2)), np.zeros((2, 12, 2))
    pred[1, :, 1] = 2.0
    assert metrics.resolve_metric("sideways").score(pred, truth).tolist() == [0.0, 2.0]
    cwd = tmp_path / "here"
    cwd.mkdir()
    (cwd / "here_metrics.py").write_text("def wobble(pred, truth):\n    return pred[..., 0, 0]\n")
    monkeypatch.chdir(cwd)  # a module beside one's data needs no installing
    assert metrics.resolve_metric("here_metrics:wobble").name == "wobble"
    with pytest.raises(metrics.GrouptronError, match="has no nothing"):
        metrics.resolve_metric("outside_metrics:nothing")
    with pytest.raises(metrics.GrouptronError, match="cannot import"):
        metrics.resolve_metric("no_such_module_here:f")
    assert "lateral" not in metrics.METRICS and "sideways" not in metrics.METRICS


@pytest.mark.slow
def test_an_outside_metric_appears_in_evaluate_and_report(
    outside: Path,
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    named = "outside_metrics:lateral,outside_metrics:FAR,sideways,miss-rate-2m"
    data = ["--data-dir", str(synthetic_data_dir), "--quiet", "--metrics", named]
    checkpoint = str(tiny_checkpoints / "grouptron-eth-central" / "best.safetensors")
    evaluate = ["evaluate", "--checkpoint", checkpoint, "--mode", "ml,best-of-5", *data]
    rows = _json(capsys, evaluate)
    assert [r["model"] for r in rows] == ["grouptron", "grouptron", "constant-velocity"]
    for row in rows:
        for name in ("lateral", "far-miss", "sideways", "miss-rate-2m"):
            assert isinstance(row[name], float) and f"{name}_ci" in row
        assert row["lateral"] == row["sideways"]  # one function by two ways
    assert main(evaluate) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "lateral" in header and "miss >0.5 m" in header and "MR 2m" in header

    report = ["report", "--checkpoints", str(tiny_checkpoints), "--split", "eth", *data]
    report += ["--derivatives", "central", "--mode", "ml,best-of-5"]
    rows = _json(capsys, report)
    ours = [r for r in rows if r["model"] == "grouptron" and r["split"] == "eth"]
    assert {r["mode"] for r in ours} == {"ml", "best-of-5"}
    assert {r["split"] for r in rows} == {"eth"}  # one split's tables, no other test set read
    assert all(isinstance(r["lateral"], float) and "far-miss" in r for r in rows)
    assert main(report) == 0
    text = capsys.readouterr().out
    for section in ("## lateral (`lateral`)", "## miss >0.5 m (`far-miss`)", "## MR 2m"):
        assert section in text
    assert "## Best of 5 samples (minADE/minFDE)" in text
    assert "--split eth --metrics " + named in text  # the command that regenerates it
    assert "lateral" not in metrics.METRICS  # registered for those commands only
