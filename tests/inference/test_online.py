"""Online calibration: radii that keep long-run coverage on a drifting sequence, strictly
causal in a replayed file, saved and resumed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.errors import GrouptronError
from grouptron.inference.calibration import QS
from grouptron.inference.online import OnlineCalibration, gaussian_radii
from grouptron.inference.predictor import Predictor
from tests.golden.compute import synthetic_tracks

Q90 = int(np.flatnonzero(np.isclose(QS, 0.9))[0])


def _drifting_scores(rng: np.random.Generator, updates: int) -> list[np.ndarray]:
    """Per update, 30 scores of one step whose scale triples halfway (a crowd densifies)."""
    return [rng.rayleigh(1.0 if u < updates // 2 else 3.0, size=30) for u in range(updates)]


def test_long_run_coverage_holds_q_where_a_static_radius_does_not() -> None:
    rng = np.random.default_rng(0)
    state = OnlineCalibration.start(horizon=1)
    static = state.radii[Q90, 0]  # the Gaussian's 90% radius: right for the first half only
    held, held_static = [], []
    for scores in _drifting_scores(rng, 2000):
        held.append(scores <= state.radii[Q90, 0])  # the radius in force when they arrive
        held_static.append(scores <= static)
        state._update(0, scores)
    assert np.mean(held) == pytest.approx(0.9, abs=0.01)
    assert np.mean(held_static) < 0.7
    assert state.coverage()[Q90, 0] == pytest.approx(np.mean(held))
    second_half = np.mean(held[1000:])
    assert second_half == pytest.approx(0.9, abs=0.02)  # it followed the drift


def test_radii_start_from_a_calibration_and_stay_ordered_in_q() -> None:
    state = OnlineCalibration.start(horizon=12)
    np.testing.assert_allclose(state.radii, gaussian_radii(QS, 12))
    state._update(3, np.full(40, 10.0))  # everything missed: every radius grows
    assert (np.diff(state.radii[:, 3]) >= 0).all()
    with pytest.raises(GrouptronError, match="learning_rate"):
        OnlineCalibration.start(horizon=12, learning_rate=0.0)


def test_a_state_is_saved_and_resumed_exactly(tmp_path: Path) -> None:
    state = OnlineCalibration.start(horizon=12)
    for h in range(12):
        state._update(h, np.random.default_rng(h).rayleigh(2.0, size=50))
    state.save(tmp_path / "state.json")
    again = OnlineCalibration.load(tmp_path / "state.json")
    np.testing.assert_array_equal(again.radii, state.radii)
    np.testing.assert_array_equal(again.missed, state.missed)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(GrouptronError, match="not a grouptron online calibration state"):
        OnlineCalibration.load(tmp_path / "bad.json")


def test_a_live_session_scores_forecasts_as_their_truths_arrive() -> None:
    tracks = synthetic_tracks()
    session = Predictor.from_checkpoint(calibration=False).stream(online_calibration=True)
    assert session.online is not None
    start = session.online.radii.copy()
    for frame in np.unique(tracks[:, 0]):
        now = tracks[tracks[:, 0] == frame]
        forecast = session.update(int(frame), now[:, 1], now[:, 2:4])
        if len(forecast):  # regions from the first forecast on, at every q
            assert np.isfinite(forecast.regions(0.99).major_m).all()
    assert session.online.scored[0] > session.online.scored[-1] > 0  # step 12: 12 steps later
    assert not np.allclose(session.online.radii, start)
    region = forecast.regions(0.9)
    assert np.isfinite(region.major_m).all() and (region.major_m > 0).all()


def test_a_replayed_file_is_strictly_causal(tmp_path: Path) -> None:
    """Forecasts at or before t get the same regions whatever the file holds after t."""
    tracks = synthetic_tracks()
    cut = 140
    full, early = tmp_path / "full.txt", tmp_path / "early.txt"
    np.savetxt(full, tracks, fmt="%.4f")
    np.savetxt(early, tracks[tracks[:, 0] <= cut], fmt="%.4f")
    written = []
    for path in (full, early):
        out = tmp_path / f"{path.stem}.csv"
        argv = ["predict", "--tracks", str(path), "--regions", "0.5,0.9", "--online"]
        assert main([*argv, "--out", str(out), "--quiet"]) == 0
        rows = np.loadtxt(out, delimiter=",", skiprows=1)
        written.append(rows[rows[:, 0] <= cut])
    assert len(written[1]) > 100
    np.testing.assert_array_equal(written[0], written[1])
    plain = tmp_path / "plain.csv"
    argv = ["predict", "--tracks", str(full), "--regions", "0.9", "--out", str(plain), "--quiet"]
    assert main(argv) == 0
    assert main([*argv[:-2], "--online-state", str(tmp_path / "s.json")]) == 2  # needs --online
