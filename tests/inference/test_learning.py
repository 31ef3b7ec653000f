"""Online learning of a site: rounds, the guard, causal replays, sessions, kept sites."""

from __future__ import annotations

import copy
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron.data.formats.track_files import TrackSource
from grouptron.errors import GrouptronError
from grouptron.inference.learning import LearningOptions, SiteLearner
from grouptron.inference.predictor import Predictor
from grouptron.inference.site_model import SITE_CARD
from grouptron.training.fine_tune import FineTune
from grouptron.workflows.predict import PredictRequest, predict_tracks
from tests.conftest import synthetic_recording

ROUNDS = LearningOptions(
    round_s=4.0,
    budget=FineTune(steps=20, batch_size=32, learning_rate=3e-3),
    min_train=20,
    min_holdout=10,
    min_holdout_steps=3,
    background=False,
)
"""Rounds every 10 steps on a few people: the mechanism at test scale."""


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 36 s recording of 14 people walking (``frame id x y``, 10 frames a step)."""
    path = tmp_path_factory.mktemp("site") / "site.txt"
    return synthetic_recording(path, seed=11, pedestrians=14, steps=90)


@pytest.fixture(scope="module")
def checkpoint(tiny_checkpoints: Path) -> Path:
    return tiny_checkpoints / "grouptron-eth-backward"


def _rows(path: Path) -> np.ndarray:
    return np.loadtxt(path)


def _replayed(checkpoint: Path, path: Path, out: Path, options: LearningOptions = ROUNDS):
    request = PredictRequest(
        TrackSource(path), out, checkpoint=checkpoint, forecast="ml", learn=options, min_points=2
    )
    return predict_tracks(request)


def test_a_replay_learns_and_is_strictly_causal(checkpoint: Path, site: Path, tmp_path: Path):
    """Every row after t removed, the forecasts made up to t are the same: the weights in use
    at t were trained and judged on tracks completed by then."""
    whole = _replayed(checkpoint, site, tmp_path / "whole.csv")
    assert whole.learning is not None and whole.learning.accepted >= 1  # the weights changed
    again = _replayed(checkpoint, site, tmp_path / "again.csv")
    rows = _rows(site)
    cut_frame = 600  # step 60: after several rounds
    cut_file = tmp_path / "cut.txt"
    np.savetxt(cut_file, rows[rows[:, 0] <= cut_frame], fmt="%.6g", delimiter="\t")
    cut = _replayed(checkpoint, cut_file, tmp_path / "cut.csv")
    early = whole.forecast.frames <= cut_frame
    assert early.sum() == len(cut.forecast.frames)
    np.testing.assert_allclose(cut.forecast.point, whole.forecast.point[early], atol=1e-5)
    assert again.learning == whole.learning  # deterministic
    np.testing.assert_array_equal(again.forecast.point, whole.forecast.point)


def test_forecasts_differ_from_the_fixed_model_only_after_an_accepted_round(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    learnt = _replayed(checkpoint, site, tmp_path / "learnt.csv")
    request = PredictRequest(
        TrackSource(site), tmp_path / "fixed.csv", checkpoint=checkpoint, forecast="ml"
    )
    fixed = predict_tracks(dataclasses.replace(request, min_points=2))
    np.testing.assert_array_equal(fixed.forecast.frames, learnt.forecast.frames)
    moved = np.abs(fixed.forecast.point - learnt.forecast.point).max(axis=(1, 2)) > 1e-6
    first_changed = learnt.forecast.frames[moved].min()
    assert first_changed >= 10 * ROUNDS.round_s / 0.4  # not before the first round's time
    assert moved.any()


def _learner(checkpoint: Path, options: LearningOptions) -> tuple[SiteLearner, Predictor]:
    predictor = Predictor.from_checkpoint(checkpoint, forecast="ml")
    learner = SiteLearner(predictor.model, predictor.config, predictor.forecast, options)
    return learner, predictor


def _feed(learner: SiteLearner, path: Path) -> None:
    rows = _rows(path)
    for frame in np.unique(rows[:, 0]):
        at = rows[:, 0] == frame
        learner.observe(frame * 0.04, rows[at, 1].astype(np.int64), rows[at, 2:4])


# 0.5 spoils the tiny model without diverging: where spoiling turns into diverging (between
# 0.7 and 2) a rounding difference in the last bit decides which one happens.
@pytest.mark.parametrize("learning_rate", [1e-9, 0.5, 30.0])
def test_rounds_that_do_not_forecast_better_keep_the_shipped_weights(
    checkpoint: Path, site: Path, learning_rate: float
) -> None:
    """Nothing learnt (a learning rate too small to move the weights), a fine-tune that
    spoils the model and one that diverges (rounds dropped, the session goes on): no round
    is accepted."""
    budget = dataclasses.replace(ROUNDS.budget, learning_rate=learning_rate)
    learner, predictor = _learner(checkpoint, dataclasses.replace(ROUNDS, budget=budget))
    _feed(learner, site)
    status = learner.status
    assert status.rounds >= 3 and status.accepted == 0 and not status.adapted
    last = status.last_difference
    if learning_rate < 1e-3:  # beyond chance, perhaps, but nanometres: not worth a swap
        assert last is not None and abs(last.mean) < 1e-6
    elif learning_rate < 1:
        assert last is not None and last.low > 0
    else:
        assert last is None  # every round diverged
    for name, value in predictor.model.state_dict().items():
        assert torch.equal(learner.model.state_dict()[name], value)


def test_learnt_weights_that_do_worse_than_the_shipped_ones_are_rolled_back(
    checkpoint: Path, site: Path
) -> None:
    """Weights in use as if learnt, but spoilt: the first round judges them against the
    shipped ones on samples they never saw, and drops them."""
    learner, _ = _learner(checkpoint, dataclasses.replace(ROUNDS, min_gain=0.99))
    spoilt = copy.deepcopy(learner.model)
    with torch.no_grad():
        for parameter in spoilt.parameters():
            parameter.add_(torch.randn_like(parameter, generator=torch.Generator().manual_seed(0)))
    learner.model = spoilt
    learner.status = dataclasses.replace(learner.status, adapted=True)
    _feed(learner, site)
    assert learner.status.rolled_back == 1 and not learner.status.adapted
    assert learner.model is learner.shipped  # min_gain 0.99: no round accepted after


def test_a_live_session_learns_in_the_background_and_keeps_its_site(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    predictor = Predictor.from_checkpoint(checkpoint, forecast="ml")
    shipped = {k: v.clone() for k, v in predictor.model.state_dict().items()}
    session = predictor.stream(learn=dataclasses.replace(ROUNDS, background=True))
    rows = _rows(site)
    for frame in np.unique(rows[:, 0]).astype(int):
        at = rows[:, 0] == frame
        session.update(int(frame), rows[at, 1], rows[at, 2:4])
    assert session.learner is not None
    session.learner.wait()
    status = session.learning
    assert status is not None and status.rounds >= 1
    for name, value in predictor.model.state_dict().items():  # the predictor's own: unchanged
        assert torch.equal(shipped[name], value)
    kept = session.save_site(tmp_path / "site")
    card = json.loads((tmp_path / "site" / SITE_CARD).read_text())
    assert card["rounds"] == status.rounds and card["base_checkpoint"].endswith(".safetensors")
    reloaded = Predictor.from_checkpoint(tmp_path / "site", forecast="ml")
    for name, value in session.learner.model.state_dict().items():
        assert torch.equal(reloaded.model.state_dict()[name], value)
    assert kept == tmp_path / "site" / "best.safetensors"
    session.close()
    worker = session.learner._worker
    assert worker is None  # stopped


def test_a_script_without_a_main_guard_learns_in_the_background(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    """The learning process is a fresh interpreter: a multiprocessing child would import
    this script again and start its loop a second time."""
    script = tmp_path / "loop.py"
    script.write_text(
        "import numpy as np\n"
        "from grouptron.inference.learning import LearningOptions\n"
        "from grouptron.inference.predictor import Predictor\n"
        "from grouptron.training.fine_tune import FineTune\n"
        "options = LearningOptions(round_s=4.0, budget=FineTune(steps=5, batch_size=32),\n"
        "                          min_train=20, min_holdout=10, min_holdout_steps=3)\n"
        f"session = Predictor.from_checkpoint({str(checkpoint)!r}).stream(learn=options)\n"
        f"rows = np.loadtxt({str(site)!r})\n"
        "for frame in np.unique(rows[:, 0]).astype(int):\n"
        "    at = rows[:, 0] == frame\n"
        "    session.update(int(frame), rows[at, 1], rows[at, 2:4])\n"
        "session.close()\n"
        "print(session.learning.rounds)\n"
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert int(done.stdout.strip().splitlines()[-1]) >= 1


def test_a_session_without_learning_has_no_site_to_keep(checkpoint: Path, tmp_path: Path):
    session = Predictor.from_checkpoint(checkpoint).stream()
    assert session.learning is None
    with pytest.raises(GrouptronError, match="learn=True"):
        session.save_site(tmp_path / "site")


def test_a_live_session_and_a_file_replay_learn_the_same_weights(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    replayed = _replayed(checkpoint, site, tmp_path / "r.csv")
    predictor = Predictor.from_checkpoint(checkpoint, forecast="ml")
    session = predictor.stream(learn=ROUNDS)
    rows = _rows(site)
    for frame in np.unique(rows[:, 0]).astype(int):
        at = rows[:, 0] == frame
        session.update(int(frame), rows[at, 1], rows[at, 2:4])
    assert session.learning == replayed.learning


def test_a_kept_site_refuses_a_calibration_made_for_the_shipped_weights(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    from grouptron.cli import main

    kept = tmp_path / "site"
    request = PredictRequest(TrackSource(site), tmp_path / "f.csv", checkpoint=checkpoint)
    request = dataclasses.replace(request, forecast="ml", learn=ROUNDS, save_site=kept)
    learning = predict_tracks(dataclasses.replace(request, min_points=2)).learning
    assert learning is not None and learning.accepted >= 1
    calibration = tmp_path / "base.json"
    argv = ["calibrate", "--tracks", str(site), "--out", str(calibration), "--forecast", "ml"]
    assert main([*argv, "--checkpoint", str(checkpoint)]) == 0
    Predictor.from_checkpoint(checkpoint, forecast="ml", calibration=calibration)  # its own
    with pytest.raises(GrouptronError, match="other weights"):
        Predictor.from_checkpoint(kept, forecast="ml", calibration=calibration)


def test_learning_and_online_calibration_run_together(checkpoint: Path, site: Path) -> None:
    """The regions' radii adapt to the forecasts of whatever weights are in use."""
    predictor = Predictor.from_checkpoint(checkpoint, forecast="ml")
    session = predictor.stream(online_calibration=True, learn=ROUNDS)
    rows = _rows(site)
    for frame in np.unique(rows[:, 0]).astype(int):
        at = rows[:, 0] == frame
        forecast = session.update(int(frame), rows[at, 1], rows[at, 2:4])
    assert session.learning is not None and session.learning.accepted >= 1
    assert session.online is not None
    regions = forecast.regions(0.9)
    assert np.isfinite(regions.major_m).all() and len(forecast)


def test_a_site_log_gives_every_sample_whatever_the_rounds(site: Path) -> None:
    """Asked every step or every 30 s, the log gives the same samples with the same
    histories: nothing completed between two rounds is lost or cut short."""
    from grouptron.config import DataConfig
    from grouptron.inference.site_samples import SiteLog

    rows = _rows(site)
    found = {}
    for every in (1, 75):
        log, after, parts = SiteLog(DataConfig(derivatives="backward"), 1.2), None, []
        for k, frame in enumerate(np.unique(rows[:, 0])):
            at = rows[:, 0] == frame
            t_s = frame * 0.04
            log.add(t_s, rows[at, 1].astype(np.int64), rows[at, 2:4])
            after = t_s if after is None else after
            if k % every == every - 1 or frame == rows[:, 0].max():
                done = log.completed(after, t_s)
                parts += [] if done is None else [done]
                after = t_s
        keys = [
            (round(float(d), 6), int(n))
            for part in parts
            for d, n in zip(part.done_s, part.samples.hist_mask.sum(axis=1), strict=True)
        ]
        found[every] = sorted(keys)
    assert len(found[1]) > 300 and found[1] == found[75]


def test_no_held_out_position_was_a_training_target(checkpoint: Path, site: Path) -> None:
    """Every training sample of a round ended a horizon (4.8 s) or more before the first
    held-out one: a person's samples a step apart share 11 of their 12 future positions."""
    learner, _ = _learner(checkpoint, ROUNDS)
    planned = []
    learner._run_round = lambda train, holdout: planned.append((train, holdout))  # type: ignore[method-assign]
    _feed(learner, site)
    assert len(planned) >= 2
    for train, holdout in planned:
        assert train.done_s.max() <= holdout.done_s.min() - 4.8 + 1e-6
        assert len(np.unique(holdout.done_s)) >= ROUNDS.min_holdout_steps


def test_close_stops_a_running_round_within_a_second_and_it_is_no_failure(
    checkpoint: Path, site: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A node told to stop while a long round runs in the learning process."""
    long_rounds = dataclasses.replace(
        ROUNDS, background=True, budget=FineTune(steps=100_000, batch_size=32)
    )
    session = Predictor.from_checkpoint(checkpoint, forecast="ml").stream(learn=long_rounds)
    rows = _rows(site)
    assert session.learner is not None
    for frame in np.unique(rows[:, 0]).astype(int):
        at = rows[:, 0] == frame
        session.update(int(frame), rows[at, 1], rows[at, 2:4])
        if session.learner.busy:
            break
    assert session.learner.busy
    import time

    time.sleep(3.0)  # the worker started and is fine-tuning
    started = time.monotonic()
    session.close(drop_round=True)
    assert time.monotonic() - started < 1.0
    assert "failed" not in caplog.text
    assert session.learning is not None and session.learning.rounds == 0  # dropped, not run


def test_a_kept_state_resumes_the_learnt_weights_and_status(
    checkpoint: Path, site: Path, tmp_path: Path
) -> None:
    predictor = Predictor.from_checkpoint(checkpoint, forecast="ml")
    session = predictor.stream(learn=ROUNDS, online_calibration=True)
    rows = _rows(site)
    for frame in np.unique(rows[:, 0]).astype(int):
        at = rows[:, 0] == frame
        session.update(int(frame), rows[at, 1], rows[at, 2:4])
    assert session.learning is not None and session.learning.rounds >= 1
    written = session.save_state(tmp_path / "state")
    assert {p.name for p in written} == {"online.json", "best.safetensors"}
    again = predictor.stream(learn=ROUNDS, online_calibration=True, state=tmp_path / "state")
    assert again.learner is not None and session.learner is not None
    for name, value in session.learner.model.state_dict().items():
        assert torch.equal(again.learner.model.state_dict()[name], value)
    assert dataclasses.replace(again.learning, seconds=0.0) == dataclasses.replace(
        session.learning, seconds=0.0
    )
    assert again.online is not None and session.online is not None
    np.testing.assert_array_equal(again.online.radii, session.online.radii)
    card = tmp_path / "state" / "site" / SITE_CARD
    edited = json.loads(card.read_text()) | {"base_weights_sha256": "0" * 64}
    card.write_text(json.dumps(edited))
    with pytest.raises(GrouptronError, match="learnt from other weights"):
        predictor.stream(learn=ROUNDS, state=tmp_path / "state")
