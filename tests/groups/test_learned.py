"""The learned group detector's parts: symmetric, scale-free pair features, a classifier that
round-trips through its file, links cut at the largest group, and a whole recording grouped."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.config import DataConfig
from grouptron.data.formats.reader import read_tracks
from grouptron.data.prepare.scene import build_scene
from grouptron.errors import GrouptronError
from grouptron.groups.learned import fit_classifier, linked_groups, load_classifier
from grouptron.groups.pair_features import FEATURES, pair_features
from grouptron.groups.scene import groups_per_step, labelled_pairs
from grouptron.presets import LEARNED_GROUPS
from grouptron.workflows.groups import GroupRule


def _walkers(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Two pairs walking side by side and one stander, over 8 steps of 0.4 s."""
    rng = np.random.default_rng(seed)
    t = np.arange(8)[:, None] * 0.4
    paths = [
        np.hstack([t * 1.2, np.zeros_like(t)]),
        np.hstack([t * 1.2, np.full_like(t, 0.7)]),
        np.hstack([5 - t, np.full_like(t, 2.0)]),
        np.hstack([5 - t, np.full_like(t, 2.6)]),
        np.full((8, 2), 2.0),
    ]
    traj = np.stack(paths) + rng.normal(scale=0.02, size=(5, 8, 2))
    traj[4] = 2.0  # the stander stands still
    return traj, np.ones((5, 8), bool)


def test_features_are_symmetric_and_lengths_scale_free() -> None:
    traj, mask = _walkers()
    pairs = np.array([[0, 1], [0, 2], [3, 4]])
    features = pair_features(traj, mask, pairs, 0.4)
    assert features.shape == (3, len(FEATURES))
    assert np.allclose(pair_features(traj, mask, pairs[:, ::-1], 0.4), features, atol=1e-5)
    alike = np.array([[0, 1], [2, 3], [3, 4]])  # a direction of travel to measure along
    features, doubled = (pair_features(k * traj, mask, alike, 0.4) for k in (1, 2))
    relative = FEATURES.index("heading_cos_mean")  # lengths and speeds come first, in units
    assert np.allclose(doubled[:, :relative], features[:, :relative], atol=1e-4)  # of the crowd
    heading = pair_features(traj, mask, pairs, 0.4)[:, FEATURES.index("heading_cos_mean")]
    assert heading[0] > 0.9 and heading[1] < -0.9  # walking alike; towards each other


def test_a_classifier_learns_pairs_and_survives_its_file(tmp_path: Path) -> None:
    traj, mask = _walkers()
    pairs = np.array([[0, 1], [2, 3], [0, 2], [1, 3], [3, 4], [0, 4], [1, 2], [2, 4]])
    together = np.array([True, True, False, False, False, False, False, False])
    features = np.concatenate([pair_features(*_walkers(s), pairs, 0.4) for s in range(20)])
    classifier = fit_classifier(features, np.tile(together, 20), steps=300)
    assert (classifier.probabilities(pair_features(traj, mask, pairs, 0.4)) > 0.5).tolist() == (
        together.tolist()
    )
    path = tmp_path / "detector/best.safetensors"
    classifier.save(path, {"trained on": "walkers"})
    loaded = load_classifier(path)
    assert np.allclose(loaded.probabilities(features), classifier.probabilities(features))
    (tmp_path / "bad.safetensors").write_bytes(b"not a file of tensors")
    with pytest.raises(GrouptronError, match="cannot read the group detector"):
        load_classifier(tmp_path / "bad.safetensors")


def test_links_are_cut_at_the_largest_group() -> None:
    chain = np.full((5, 5), np.inf)
    np.fill_diagonal(chain, 0.0)
    for a, b, d in ((0, 1, 0.1), (1, 2, 0.2), (2, 3, 0.1), (3, 4, 0.25)):
        chain[a, b] = chain[b, a] = d
    assert linked_groups(chain, 0.3, None).tolist() == [0, 0, 0, 0, 0]
    cut = linked_groups(chain, 0.3, 2)
    assert np.bincount(cut).max() <= 2 and cut[0] == cut[1] and cut[2] == cut[3]


def test_a_recording_is_grouped_by_a_classifier(synthetic_data_dir: Path) -> None:
    scene = build_scene(read_tracks(synthetic_data_dir / "eth/test/scene5.txt"), DataConfig())
    labels = {int(p): int(p) // 2 for p in scene.ped_id}  # made-up pairs: a shape check
    features, together, steps = labelled_pairs(scene, labels, every=2)
    assert len(features) == len(together) == len(steps) > 0
    classifier = fit_classifier(features, together, steps=50)
    found = list(groups_per_step(scene, LEARNED_GROUPS, every=5, classifier=classifier))
    assert found and all(np.bincount(f.labels).max() <= 6 for f in found)
    assert all(np.allclose(np.diag(f.distances), 0.0) for f in found)


def test_the_commands_take_the_shipped_detector(
    synthetic_data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from grouptron.cli import main

    tracks = str(synthetic_data_dir / "eth/test/scene5.txt")
    labels = tmp_path / "groups.txt"
    labels.write_text("0 1\n2 3\n")
    evaluate = ["groups", "evaluate", "--tracks", tracks, "--labels", str(labels)]
    assert main([*evaluate, "--detector", "learned", "--format", "json"]) == 0
    scene, per_ego = json.loads(capsys.readouterr().out)["results"]
    assert scene["scope"] == "scene" and 0.0 <= scene["gmitre_f1"] <= 1.0
    assert "gmitre_f1" not in per_ego  # a partition's score: the scene-wide one only
    assert main([*evaluate, "--detector", "learned", "--linkage", "average"]) == 2
    assert "--detector learned links the pairs" in capsys.readouterr().err
    out = tmp_path / "groups.csv"
    assert (
        main(["groups", "detect", "--tracks", tracks, "--detector", "learned", "--out", str(out)])
        == 0
    )
    assert out.read_text().count("\n") > 1


def test_the_learned_detector_is_the_default_unless_the_rule_is_asked_for() -> None:
    assert GroupRule().configs() == [LEARNED_GROUPS]
    assert GroupRule(max_group_size=4).configs()[0].max_group_size == 4  # both take a limit
    for rule in (
        GroupRule(max_distance_m=1.2),
        GroupRule(velocity_weight_s=0.0),
        GroupRule(linkage="average"),
        GroupRule(rule="count"),
        GroupRule(distance="modified"),
        GroupRule(detector="distance"),
    ):
        assert all(config.detector == "distance" for config in rule.configs()), rule


def test_a_detector_file_of_one_network_is_refused(tmp_path: Path) -> None:
    features = np.random.default_rng(0).normal(size=(40, len(FEATURES)))
    classifier = fit_classifier(features, features[:, 0] > 0, steps=5, members=2)
    single = {k: (v[0] if v.ndim > 1 and k != "mean" else v) for k, v in vars(classifier).items()}
    path = tmp_path / "old.safetensors"
    type(classifier)(**single).save(path, {})  # the layout before networks were averaged
    with pytest.raises(GrouptronError, match="other features"):
        load_classifier(path)
