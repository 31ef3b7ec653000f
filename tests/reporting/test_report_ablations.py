"""Runs that match no named model (a ``--set`` ablation, a model of the forecaster interface)
reach the report's tables, named by the settings in which they differ."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from grouptron.config import ExperimentConfig
from grouptron.evaluation.results import EvaluationResult
from grouptron.model.checkpoint import load_checkpoint, save_checkpoint
from grouptron.presets import experiment_preset, run_label
from grouptron.reporting.report import find_checkpoints
from grouptron.reporting.stats import Report
from grouptron.reporting.tables import report_markdown

ABLATION = 'trajectron++ [model.edge_aggregation="mean"]'


def _ablated(source: Path, target: Path) -> Path:
    """``source``'s weights under a config with the mean edge aggregation switched on, as
    ``grouptron train --set model.edge_aggregation=mean`` would store it."""
    checkpoint = load_checkpoint(source)
    model = dataclasses.replace(checkpoint.config.model, edge_aggregation="mean")
    config = dataclasses.replace(checkpoint.config, model=model)
    target.parent.mkdir(parents=True)
    save_checkpoint(target, dataclasses.replace(checkpoint, config=config))
    return target


def test_runs_are_named_by_the_settings_in_which_they_differ() -> None:
    assert run_label(experiment_preset("eth", "grouptron-robust")) == "grouptron-robust"
    mean = dataclasses.replace(ExperimentConfig().model, edge_aggregation="mean")
    assert run_label(dataclasses.replace(ExperimentConfig(), model=mean)) == ABLATION
    outside = ExperimentConfig(model_name="pkg.mod:Model", model_settings={"hidden": 8})
    assert run_label(outside) == "pkg.mod:Model [model_settings.hidden=8]"


def test_an_ablation_is_found_and_tabled(tiny_checkpoints: Path, tmp_path: Path) -> None:
    plain = tiny_checkpoints / "trajectron++-eth-central/best.safetensors"
    _ablated(plain, tmp_path / "ablation/best.safetensors")
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain/best.safetensors").write_bytes(plain.read_bytes())
    plain_run, ablation = find_checkpoints(tmp_path, ("central",))
    assert plain_run.model == "trajectron++"  # the tiny model's widths, the switches named
    assert ablation.model.startswith("trajectron++ [") and "group_encoder" not in ablation.model
    assert 'model.edge_aggregation="mean"' in ablation.model
    assert "model.decoder_hidden=16" in ablation.model
    mine = find_checkpoints(tmp_path, ("central",), ("trajectron++",))  # an ablation: its model's
    assert [c.model for c in mine] == [plain_run.model, ablation.model]
    rows = [
        EvaluationResult("eth", model, None, 10, ade, 2 * ade, "ml", None, "x", "central")
        for model, ade in (("trajectron++", 0.5), (ablation.model, 0.4))
    ]
    text = report_markdown(Report(rows, [], []), ("central",), "grouptron report --mode ml")
    assert f"| {ablation.model} | ours, central | 0.400/0.800 |" in text
