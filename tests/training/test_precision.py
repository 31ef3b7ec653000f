"""The precision switch: explicit choices, a measured auto, and resuming across a change."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.training import precision
from grouptron.training.precision import cpu_flags, resolve_precision

CPU = torch.device("cpu")


def test_explicit_choices_and_flags() -> None:
    assert resolve_precision("fp32", CPU) is False
    assert resolve_precision("bf16", CPU) is True
    assert resolve_precision("auto", CPU, flags=frozenset({"avx2"})) is False  # emulated
    with pytest.raises(GrouptronError, match="precision must be one of"):
        resolve_precision("fp16", CPU)
    flags = cpu_flags("processor : 0\nflags\t\t: fpu sse avx512_bf16 avx2\n")
    assert "avx512_bf16" in flags


@pytest.mark.parametrize(("speedup", "chosen"), [(1.75, True), (0.73, False), (1.05, False)])
def test_auto_takes_bf16_only_where_it_is_measured_faster(
    monkeypatch: pytest.MonkeyPatch, speedup: float, chosen: bool
) -> None:
    monkeypatch.setattr(precision, "bf16_speedup_cpu", lambda threads: speedup)
    assert resolve_precision("auto", CPU, flags=frozenset({"avx512_bf16"})) is chosen


def test_a_resumed_run_may_change_precision_and_records_each_epoch(
    synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.json"
    small = {"history_hidden": 8, "edge_hidden": 8, "future_hidden": 8, "latent_values": 5,
             "p_z_hidden": 8, "decoder_hidden": 16}  # fmt: skip
    config.write_text(json.dumps({"model": small, "train": {"batch_size": 128, "threads": 1}}))
    common = ["train", "--split", "eth", "--config", str(config), "--out", str(tmp_path / "run")]
    common += ["--data-dir", str(synthetic_data_dir), "--quiet"]
    assert main([*common, "--epochs", "1", "--precision", "fp32"]) == 0
    assert main([*common, "--epochs", "2", "--resume", "--precision", "bf16"]) == 0
    assert "ran in fp32 so far; the remaining epochs run in bf16" in capsys.readouterr().out
    assert main([*common, "--epochs", "3", "--resume"]) == 0  # keeps the run's (now bf16)
    records = [json.loads(line) for line in (tmp_path / "run/metrics.jsonl").open()]
    assert [r["precision"] for r in records] == ["fp32", "bf16", "bf16"]
    card = (tmp_path / "run/README.md").read_text()
    assert "fp32 (epoch 1), bf16 (epochs 2-3)" in card
