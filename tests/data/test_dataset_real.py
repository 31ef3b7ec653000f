"""The real benchmark: exact sample counts, UNIV-N, and a naive re-computation of the features."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.config import DataConfig
from grouptron.constants import EXPECTED_TEST_SAMPLES, SPLITS
from grouptron.data.datasets.dataset import build_part, load_part
from grouptron.data.datasets.download import parse_checksums, shipped_checksums
from grouptron.data.datasets.locate import split_files
from grouptron.data.datasets.subsets import UnivN, agents_predicted, time_step_ids, univ_n_mask

pytestmark = pytest.mark.realdata


def test_shipped_checksums_equal_the_benchmark_list(eth_ucy_dir: Path) -> None:
    assert shipped_checksums() == parse_checksums((eth_ucy_dir / "SHA256SUMS").read_text())


@pytest.mark.parametrize("scheme", ["central", "backward"])
def test_test_sample_counts_are_the_reference_ones(eth_ucy_dir: Path, scheme: str) -> None:
    config = DataConfig(derivatives=scheme)  # type: ignore[arg-type]
    counts = {s: len(load_part(eth_ucy_dir, s, "test", config).samples) for s in SPLITS}
    assert counts == EXPECTED_TEST_SAMPLES


def test_univ_n_counts_match_a_direct_count_of_the_raw_rows(eth_ucy_dir: Path) -> None:
    samples = load_part(eth_ucy_dir, "univ", "test", DataConfig()).samples
    files = split_files(eth_ucy_dir, "univ", "test")
    for index, path in enumerate(files):
        raw = np.loadtxt(path)
        frames, per_frame = np.unique(raw[:, 0], return_counts=True)
        steps = ((frames - frames.min()) // 10).astype(int)
        present = dict(zip(steps.tolist(), per_frame.tolist(), strict=True))
        mine = samples.step[samples.scene_index == index]
        expected = np.array([present[int(t)] for t in mine])
        np.testing.assert_array_equal(samples.num_present[samples.scene_index == index], expected)
    present = [int(univ_n_mask(samples, UnivN(n, "present")).sum()) for n in (40, 45, 50)]
    assert present == [16599, 13115, 8268]


def test_univ_n_paper_definition_counts_predicted_agents_per_time_step(
    eth_ucy_dir: Path,
) -> None:
    """The paper's UNIV-N: time steps with >= N test samples; counts measured on the data."""
    samples = load_part(eth_ucy_dir, "univ", "test", DataConfig()).samples
    steps = time_step_ids(samples)
    for n, expected_samples, expected_steps in ((40, 3222, 72), (45, 1596, 33), (50, 572, 11)):
        keep = univ_n_mask(samples, UnivN(n))
        assert int(keep.sum()) == expected_samples
        assert len(np.unique(steps[keep])) == expected_steps
        assert (agents_predicted(samples)[keep] >= n).all()


@pytest.mark.parametrize("scheme", ["central", "backward"])
def test_features_match_a_naive_per_sample_computation(eth_ucy_dir: Path, scheme: str) -> None:
    """Recompute every eth test sample with plain loops straight from the raw rows."""
    config = DataConfig(derivatives=scheme)  # type: ignore[arg-type]
    (path,) = split_files(eth_ucy_dir, "eth", "test")
    samples = build_part([path], config, min_history=8).samples
    raw = np.loadtxt(path)
    raw[:, 2:] -= raw[:, 2:].mean(axis=0)
    step_of = ((raw[:, 0] - raw[:, 0].min()) // 10).astype(int)
    tracks: dict[int, dict[int, np.ndarray]] = {}
    for ped in np.unique(raw[:, 1]).astype(int):
        rows = raw[:, 1] == ped
        order = np.argsort(step_of[rows])
        xy = raw[rows][order, 2:]
        if len(xy) < 2:
            continue
        if scheme == "central":
            vel = np.gradient(xy, 0.4, axis=0)
            acc = np.gradient(vel, 0.4, axis=0)
        else:
            vel = np.diff(xy, axis=0, prepend=xy[:1]) / 0.4  # 0 at the first point
            acc = np.diff(vel, axis=0, prepend=vel[:1]) / 0.4
            acc[:2] = 0.0  # needs two earlier points
        states = np.concatenate([xy, vel, acc], axis=1)
        tracks[ped] = dict(zip(step_of[rows][order].tolist(), states, strict=True))
    scale = np.array(config.state_scale)
    ped_ids = sorted(tracks)
    checked = 0
    for s in range(0, len(samples), 7):  # every 7th sample keeps the loop short
        ego = ped_ids[samples.track[s]]
        t = int(samples.step[s])
        now = tracks[ego][t]
        hist = np.array([tracks[ego][k] for k in range(t - 7, t + 1)])
        expected_hist = (hist - np.r_[now[:2], 0, 0, 0, 0]) / scale
        np.testing.assert_allclose(samples.hist_st[s], expected_hist, atol=1e-5)
        near = [
            p
            for p in ped_ids
            if p != ego and t in tracks[p] and np.linalg.norm(tracks[p][t][:2] - now[:2]) <= 3.0
        ]
        nbr_sum = np.zeros((8, 6))
        weight_sum = 0.0
        edges = slice(samples.nbr_offsets[s], samples.nbr_offsets[s + 1])
        for p, single in zip(near, samples.nbr_hist_st[edges], strict=True):
            expected_single = np.zeros((8, 6))
            for h, k in enumerate(range(t - 7, t + 1)):
                if k in tracks[p]:
                    expected_single[h] = (tracks[p][k] - now) / scale
            np.testing.assert_allclose(single, expected_single, atol=1e-4)
            nbr_sum += expected_single
            w = 0.0
            for lag, w_lag in enumerate((0.25, 0.5, 0.75, 1.0)):
                k = t - lag
                if k in tracks[p] and k in tracks[ego]:
                    w += w_lag * (np.linalg.norm(tracks[p][k][:2] - tracks[ego][k][:2]) <= 3.0)
            weight_sum += min(w, 1.0)
        assert samples.num_neighbours[s] == len(near)
        np.testing.assert_allclose(samples.nbr_sum_st[s], nbr_sum, atol=1e-4)
        assert samples.edge_weight_sum[s] == pytest.approx(weight_sum, abs=1e-6)
        future = np.array([tracks[ego][k][:2] for k in range(t + 1, t + 13)]) - now[:2]
        np.testing.assert_allclose(samples.fut_rel_m[s], future, atol=1e-5)
        checked += 1
    assert checked > 50
