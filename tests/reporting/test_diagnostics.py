"""Diagnostics: scores by density and evaluation-time ablations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.subsets import density_masks
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import score_samples
from grouptron.groups.cache import load_groups
from grouptron.model.checkpoint import load_trained_model


class _Counts:
    def __init__(self, counts: list[int]) -> None:
        self.num_neighbours = np.asarray(counts)


def test_density_bins_cover_every_count_once() -> None:
    counts = [0, 1, 2, 3, 5, 6, 9, 10, 24, 25, 80]
    masks = density_masks(_Counts(counts))  # type: ignore[arg-type]
    assert list(masks) == [
        "neighbours 0", "neighbours 1-2", "neighbours 3-5", "neighbours 6-9",
        "neighbours 10-24", "neighbours 25+",
    ]  # fmt: skip
    assert np.array_equal(sum(m.astype(int) for m in masks.values()), np.ones(len(counts)))
    assert masks["neighbours 25+"].tolist()[-2:] == [True, True]
    assert masks["neighbours 6-9"].sum() == 2


@pytest.fixture(scope="module")
def grouptron(tiny_checkpoints: Path, synthetic_data_dir: Path):
    model, config = load_trained_model(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    samples = load_part(synthetic_data_dir, "eth", "test", config.data).samples
    groups = load_groups(
        synthetic_data_dir, "eth", "test", config.data, groups=config.groups, samples=samples
    )
    return model, config, samples, groups


def test_ablations_change_what_the_model_sees(grouptron) -> None:
    model, config, samples, groups = grouptron

    def fde(ablate: tuple[str, ...]) -> np.ndarray:
        (scores,) = score_samples(model, config, samples, ("ml",), groups=groups, ablate=ablate)
        return scores.fde

    plain, no_edges, no_scene = fde(()), fde(("edges",)), fde(("scene",))
    assert not np.allclose(plain, no_edges) and not np.allclose(plain, no_scene)
    np.testing.assert_array_equal(plain, fde(()))  # deterministic, so the changes are real
    with pytest.raises(GrouptronError, match="unknown ablation"):
        fde(("history",))


def test_the_command_line_scores_by_density_and_refuses_a_scene_ablation_without_one(
    tiny_checkpoints: Path, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    common = ["evaluate", "--data-dir", str(synthetic_data_dir), "--quiet", "--format", "json"]
    ckpt = str(tiny_checkpoints / "grouptron-eth-central/best.safetensors")
    assert main([*common, "--checkpoint", ckpt, "--by-density", "--ablate", "edges"]) == 0
    out = capsys.readouterr().out
    assert '"subset": "neighbours 1-2"' in out and "grouptron without edges" in out
    plain = str(tiny_checkpoints / "trajectron++-eth-central/best.safetensors")
    assert main([*common, "--checkpoint", plain, "--ablate", "scene"]) == 2
    assert "needs a Grouptron checkpoint" in capsys.readouterr().err
