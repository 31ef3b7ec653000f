"""Scene-level metrics pinned on hand-made scenes: TrajNet++'s collision definition (two radii
of 0.1 m, read at the steps and halfway between them, only within one moment), Col-I against
forecasts and Col-II against true paths, joint best-of-K chosen per moment; and their path
through ``grouptron evaluate --metrics``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.evaluation import metrics
from grouptron.evaluation.scene_metrics import (
    SceneForecasts,
    closest_approach_m,
    collisions_among_forecasts,
    collisions_with_truths,
    joint_ade,
    joint_fde,
    moment_ids,
    moment_pairs,
)

H = 12


def _walk(start: tuple[float, float], step: tuple[float, float]) -> np.ndarray:
    """(H, 2) a straight walk from ``start`` by ``step`` per forecast step."""
    return np.asarray(start) + np.arange(1, H + 1)[:, None] * np.asarray(step)


def _scene(
    forecasts: list[np.ndarray], truths: list[np.ndarray], moment: list[int]
) -> SceneForecasts:
    """Forecasts (each (K, H, 2) or (H, 2)), truths (each (H, 2)) and moments, stacked."""
    stacked = [f if f.ndim == 3 else f[None] for f in forecasts]
    return SceneForecasts(np.stack(stacked), np.stack(truths), np.asarray(moment))


def test_moments_pair_only_people_of_the_same_scene_and_step() -> None:
    moment = moment_ids(np.array([0, 0, 1, 0, 0]), np.array([3, 3, 3, 4, 3]))
    first, second = moment_pairs(moment)
    pairs = sorted(zip(first.tolist(), second.tolist(), strict=True))
    assert pairs == [(0, 1), (0, 4), (1, 0), (1, 4), (4, 0), (4, 1)]


def test_two_people_within_two_radii_collide_and_just_beyond_do_not() -> None:
    here = _walk((0.0, 0.0), (0.1, 0.0))
    close = here + np.array([0.0, 0.2])  # 2 x 0.1 m apart all along: a collision (<=)
    far = here + np.array([0.0, 0.21])
    scene = _scene([here, close], [here, close], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [1.0, 1.0]
    scene = _scene([here, far], [here, far], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [0.0, 0.0]


def test_paths_that_cross_between_two_steps_collide() -> None:
    # 0.276 m apart at every step, 0.19 m halfway between steps 6 and 7
    east = _walk((-1.3, 0.0), (0.2, 0.0))
    west = _walk((1.3, 0.19), (-0.2, 0.0))
    gaps = np.linalg.norm(east - west, axis=-1)
    assert gaps.min() > 0.2
    assert closest_approach_m(east, west) == pytest.approx(0.19)
    scene = _scene([east, west], [east, west], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [1.0, 1.0]


def test_a_one_step_horizon_reads_that_step_alone() -> None:
    here, near, far = np.zeros((1, 2)), np.array([[0.0, 0.15]]), np.array([[0.0, 0.5]])
    scene = _scene([here, near, far], [here, near, far], [0, 0, 1])
    assert collisions_among_forecasts(scene).tolist() == [1.0, 1.0, 0.0]


def test_people_at_the_same_place_in_different_moments_do_not_collide() -> None:
    here = _walk((0.0, 0.0), (0.1, 0.0))
    scene = _scene([here, here], [here, here], [0, 1])
    assert collisions_among_forecasts(scene).tolist() == [0.0, 0.0]
    assert collisions_with_truths(scene).tolist() == [0.0, 0.0]


def test_col_ii_reads_the_others_true_paths_not_their_forecasts() -> None:
    mine = _walk((0.0, 0.0), (0.1, 0.0))
    their_truth = mine + np.array([0.0, 0.1])  # where the other really walked: in my way
    their_forecast = mine + np.array([0.0, 3.0])  # where they were forecast: far away
    my_truth = mine + np.array([0.0, -3.0])
    scene = _scene([mine, their_forecast], [my_truth, their_truth], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [0.0, 0.0]
    assert collisions_with_truths(scene).tolist() == [1.0, 0.0]


def test_sampled_futures_collide_sample_by_sample() -> None:
    mine = np.stack([_walk((0.0, 0.0), (0.1, 0.0)), _walk((0.0, 0.0), (0.1, 0.0))])
    theirs = np.stack([mine[0] + [0.0, 0.1], mine[1] + [0.0, 5.0]])  # near in sample 0 only
    scene = _scene([mine, theirs], [mine[0], theirs[0]], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [0.5, 0.5]
    apart = np.stack([mine[0], mine[1] + [0.0, 10.0]])  # my two futures 10 m apart
    crossed = np.stack([apart[1] + [0.0, 0.1], apart[0] + [0.0, 0.1]])  # each near my other
    scene = _scene([apart, crossed], [mine[0], theirs[0]], [0, 0])
    assert collisions_among_forecasts(scene).tolist() == [0.0, 0.0]


def test_joint_best_of_k_is_chosen_per_moment_not_per_person() -> None:
    truth_a, truth_b = np.zeros((H, 2)), np.full((H, 2), 10.0)
    east = np.array([1.0, 0.0])
    # a: sample 0 exact, sample 1 1 m off; b: sample 0 3 m off, sample 1 1 m off
    a = np.stack([truth_a, truth_a + east])
    b = np.stack([truth_b + 3 * east, truth_b + east])
    alone = np.stack([truth_a + 2 * east, truth_a + 0.5 * east])  # its own moment
    scene = _scene([a, b, alone], [truth_a, truth_b, truth_a], [0, 0, 1])
    # per person the best would be 0, 1 and 0.5; the moment's best sample is 1 (mean 1 < 1.5)
    assert joint_ade(scene) == pytest.approx([1.0, 1.0, 0.5])
    assert joint_fde(scene) == pytest.approx([1.0, 1.0, 0.5])


def test_joint_errors_of_one_forecast_are_ade_and_fde() -> None:
    rng = np.random.default_rng(0)
    truths = rng.normal(size=(6, H, 2))
    forecasts = truths + rng.normal(size=(6, H, 2))
    scene = SceneForecasts(forecasts[:, None], truths, np.array([0, 0, 0, 1, 1, 2]))
    assert joint_ade(scene) == pytest.approx(metrics.ade(forecasts, truths))
    assert joint_fde(scene) == pytest.approx(metrics.fde(forecasts, truths))


def test_scene_metrics_are_named_and_scored_only_when_asked() -> None:
    assert "col-i" not in metrics.METRICS
    with metrics.scoring(("col-i", "jade")) as chosen:
        assert [m.name for m in chosen] == ["col-i", "jade"]
        assert set(metrics.scene_metrics()) == {"col-i", "jade"}
        assert "col-i" not in metrics.per_person_metrics()
    assert "col-i" not in metrics.METRICS
    with pytest.raises(GrouptronError, match="col-ii"):
        metrics.resolve_metric("col-iii")


@pytest.mark.slow
def test_evaluate_prints_every_scene_metric_with_an_interval(
    tiny_checkpoints: Path, synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    checkpoint = str(tiny_checkpoints / "trajectron++-eth-central" / "best.safetensors")
    command = ["evaluate", "--checkpoint", checkpoint, "--split", "eth"]
    command += ["--data-dir", str(synthetic_data_dir), "--mode", "ml,best-of-20"]
    command += ["--metrics", "col-i,col-ii,jade,jfde", "--format", "json"]
    capsys.readouterr()
    assert main(command) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert {row.get("mode") for row in rows} >= {"ml", "best-of-20"}
    for row in rows:
        for name in ("col-i", "col-ii", "jade", "jfde"):
            low, high = row[f"{name}_ci"]
            assert low <= row[name] <= high
        if row.get("mode") == "ml":  # one forecast: the joint errors are the person's
            assert row["jade"] == pytest.approx(row["ade"])
        if row.get("mode") == "best-of-20":  # the moment's best sample: no better than each's
            assert row["jade"] >= row["ade"] - 1e-12
