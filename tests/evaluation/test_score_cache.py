"""Scores kept between reports: read back unchanged, and never served once anything changed."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.samples import SampleSet
from grouptron.evaluation import score_cache
from grouptron.evaluation.evaluate import score_samples
from grouptron.evaluation.report import ReportCheckpoint, ReportSettings, score_checkpoint
from grouptron.evaluation.score_cache import cached_score_samples, scoring_sources
from grouptron.model.cvae import TrajectronCVAE
from tests.evaluation.test_report import _eth_test

MODES = ("ml", "best-of-20")
EthTest = tuple[TrajectronCVAE, ExperimentConfig, SampleSet]


@pytest.fixture
def eth(tiny_checkpoints: Path, synthetic_data_dir: Path) -> EthTest:
    """A fresh copy of the tiny eth model (one test changes its weights) and its test set."""
    return _eth_test(tiny_checkpoints, synthetic_data_dir)


def _count_scored(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, ...]]:
    """The modes of every call that really scores (a cache miss)."""
    calls: list[tuple[str, ...]] = []

    def counting(*args, **kwargs):
        calls.append(tuple(args[3]))
        return score_samples(*args, **kwargs)

    monkeypatch.setattr(score_cache, "score_samples", counting)
    return calls


def test_cached_scores_are_read_back_unchanged_and_only_missing_modes_are_scored(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    first = cached_score_samples(tmp_path, model, config, samples, MODES, batch_size=7)
    again = cached_score_samples(tmp_path, model, config, samples, (*MODES, "mean"), batch_size=7)
    assert calls == [MODES, ("mean",)]
    fresh = score_samples(model, config, samples, (*MODES, "mean"), batch_size=7)
    for stored, direct in zip((*first, *again), (*fresh[:2], *fresh), strict=True):
        assert stored.mode == direct.mode
        for name in ("ade", "fde", "nll"):
            np.testing.assert_array_equal(getattr(stored, name), getattr(direct, name))


def test_any_change_of_weights_samples_or_settings_scores_again(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    calls = _count_scored(monkeypatch)
    cached_score_samples(tmp_path, model, config, samples, ("ml",))
    cached_score_samples(tmp_path, model, config, samples, ("ml",), batch_size=5)
    cached_score_samples(tmp_path, model, config, samples, ("ml",), ablate=("edges",))
    cached_score_samples(tmp_path, model, config, samples, ("best-of-20",), seed=0)
    cached_score_samples(tmp_path, model, config, samples, ("best-of-20",), seed=1)
    moved = dataclasses.replace(samples, fut_rel_m=samples.fut_rel_m + 0.01)
    cached_score_samples(tmp_path, model, config, moved, ("ml",))
    with torch.no_grad():
        next(model.parameters()).add_(1e-3)
    cached_score_samples(tmp_path, model, config, samples, ("ml",))
    assert len(calls) == 7
    cached_score_samples(tmp_path, model, config, samples, ("ml",))  # the last one, kept
    assert len(calls) == 7


def test_unreadable_or_mismatched_cache_files_are_scored_again(
    eth: EthTest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, config, samples = eth
    (first,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    (stored,) = tmp_path.glob("*.npz")
    calls = _count_scored(monkeypatch)
    stored.write_bytes(b"not an npz")
    (again,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    np.savez(stored, ade=first.ade[:3], fde=first.fde[:3], nll=first.nll[:3])
    (third,) = cached_score_samples(tmp_path, model, config, samples, ("ml",))
    assert len(calls) == 2
    np.testing.assert_array_equal(first.fde, again.fde)
    np.testing.assert_array_equal(first.fde, third.fde)


def test_a_sampling_mode_scores_the_same_whichever_modes_come_before_it(eth: EthTest) -> None:
    model, config, samples = eth
    few = samples.subset(np.arange(len(samples)) < 6)
    _, nll_after = score_samples(model, config, few, ("best-of-20", "nll"), batch_size=64)
    (nll_alone,) = score_samples(model, config, few, ("nll",), batch_size=64)
    np.testing.assert_array_equal(nll_after.nll, nll_alone.nll)


def test_the_scoring_code_covers_the_models_and_what_scoring_imports() -> None:
    names = {path.name for path in scoring_sources(("grouptron.model.grouptron",))}
    assert {"evaluate.py", "metrics.py", "predict.py", "cvae.py", "batch.py"} <= names
    assert {"grouptron.py", "stgcn.py"} <= names  # the model's own class and its encoders
    assert not {"report.py", "app.py", "forecasts.py"} & names  # tables, CLI, plots: not scoring


def test_a_report_run_again_reads_every_score_from_the_cache(
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    path = tiny_checkpoints / "grouptron-eth-central/best.safetensors"
    entry = ReportCheckpoint("grouptron", "eth", "central", path)
    settings = ReportSettings(
        modes=("ml", "nll"), nll_max_samples=5, diagnostics=True, score_cache=tmp_path
    )
    first = score_checkpoint(entry, synthetic_data_dir, settings)
    calls = _count_scored(monkeypatch)
    again = score_checkpoint(entry, synthetic_data_dir, settings)
    assert calls == []
    assert again.rows == first.rows
    np.testing.assert_array_equal(again.ablated["scene"].fde, first.ablated["scene"].fde)
