"""One plausibility rule for every input path: an impossible jump is repaired, named in a
warning, and never changes anyone else's forecast."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.data.formats.glitches import MAX_JUMP_SPEED_MPS, find_glitches, repair_rows
from grouptron.data.formats.layout import RecordingFormat, parse_columns
from grouptron.data.formats.reader import TrackTable
from grouptron.data.formats.recording import read_resampled
from grouptron.inference.predictor import Predictor
from tests.conftest import write_tracks

STEPS = 16
GLITCH = (8, 1)
"""(step, person) of the row that a tracker put at x = 5000 m."""


def crowd_rows() -> np.ndarray:
    """(R, 4) ``frame id x y``: four people walking straight side by side, 0.8 m apart, so
    that each is the others' neighbour (positions exact on a line: interpolation restores
    a lost one exactly)."""
    return np.asarray(
        [(10 * k, p, 0.5 * k, 0.8 * p) for k in range(STEPS) for p in range(4)], dtype=float
    )


def with_glitch(rows: np.ndarray) -> np.ndarray:
    glitched = rows.copy()
    step, person = GLITCH
    glitched[(rows[:, 0] == 10 * step) & (rows[:, 1] == person), 2] = 5000.0
    return glitched


def test_a_spike_is_interpolated_a_bad_end_dropped_and_a_lasting_jump_split() -> None:
    time_s = np.arange(10) * 0.4
    ids = np.zeros(10)
    walk = np.column_stack([1.2 * time_s, np.zeros(10)])
    spike, first, last, lasting = (walk.copy() for _ in range(4))
    spike[4, 0] = first[0, 0] = last[9, 0] = 5000.0
    lasting[5:, 0] += 100.0
    found = find_glitches(ids, time_s, spike)
    assert found.spikes.tolist() == [4] and np.allclose(found.pos_m, walk)
    assert find_glitches(ids, time_s, first).dropped.tolist() == [0]
    assert find_glitches(ids, time_s, last).dropped.tolist() == [9]
    found = find_glitches(ids, time_s, lasting)
    assert found.splits.tolist() == [5] and not len(found.spikes) and not len(found.dropped)
    # Fast but possible (a sprint at 14 m/s) is no glitch; rows in any order.
    sprint = np.column_stack([14.0 * time_s, np.zeros(10)])
    assert not len(find_glitches(ids, time_s, sprint))
    order = np.random.default_rng(0).permutation(10)
    assert find_glitches(ids[order], time_s[order], spike[order]).spikes.tolist() == [
        int(np.flatnonzero(order == 4)[0])
    ]


def test_a_lasting_jump_keeps_the_callers_id_on_the_track_the_person_is_on_now() -> None:
    rows = crowd_rows()
    rows[(rows[:, 1] == 2) & (rows[:, 0] >= 100), 2] += 50.0  # id 2 swapped at step 10
    repaired, found = repair_rows(rows, 0.04)
    assert len(found.splits) == 1
    now = repaired[repaired[:, 0] >= 100]
    assert sorted(set(now[:, 1].tolist())) == [0, 1, 2, 3]
    before = repaired[(repaired[:, 0] < 100) & ~np.isin(repaired[:, 1], [0, 1, 3])]
    assert set(before[:, 1].tolist()) == {4.0}  # a fresh id above every id
    assert MAX_JUMP_SPEED_MPS == 15.0


def test_the_api_repairs_the_5000_m_row_names_it_and_leaves_everyone_else_alone(
    tiny_checkpoints: Path, caplog: pytest.LogCaptureFixture
) -> None:
    predictor = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    clean = crowd_rows()
    for t in (80, 100, 150):  # the glitch at the forecast frame, shortly before, long before
        glitched = with_glitch(clean[clean[:, 0] <= t])
        row = int(np.flatnonzero(glitched[:, 2] == 5000.0)[0])
        if t == 80:  # the last sighting: dropped, exactly as a missed detection
            expected = predictor.predict(np.delete(clean[clean[:, 0] <= t], row, axis=0))
        else:  # a spike before the forecast frame: restored exactly (a straight walk)
            expected = predictor.predict(clean[clean[:, 0] <= t])
        with caplog.at_level(logging.WARNING):
            caplog.clear()
            got = predictor.predict(glitched)
        assert f"row {row} (id 1, x=5000" in caplog.text
        assert ("dropped" if t == 80 else "interpolation") in caplog.text
        assert np.array_equal(got.ids, expected.ids)
        assert np.allclose(got.point, expected.point, atol=1e-9)


def test_the_cli_repairs_the_5000_m_row_and_its_csv_equals_the_clean_files(
    tiny_checkpoints: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rows = [tuple(r) for r in crowd_rows().tolist()]
    clean = write_tracks(tmp_path / "clean.txt", rows)
    glitched = write_tracks(
        tmp_path / "glitched.txt", [tuple(r) for r in with_glitch(crowd_rows())]
    )
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    outputs = []
    for tracks in (clean, glitched):
        out = tmp_path / f"{tracks.stem}.csv"
        with caplog.at_level(logging.WARNING):
            caplog.clear()
            argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks)]
            assert main([*argv, "--out", str(out), "--quiet"]) == 0
        outputs.append(out.read_text())
    line = 1 + int(np.flatnonzero(with_glitch(crowd_rows())[:, 2] == 5000.0)[0])
    assert "glitched.txt: 1 impossible jump(s)" in caplog.text
    assert f"line {line} (id 1, x=5000" in caplog.text and "interpolation" in caplog.text
    assert outputs[0] == outputs[1]


def read_corridor(path: Path, lines: list[str], caplog: pytest.LogCaptureFixture) -> TrackTable:
    """Write ``id frame x y`` lines (16 fps, centimetres) and read them resampled to 0.4 s,
    keeping the warnings in ``caplog``."""
    path.write_text("\n".join(lines) + "\n")
    fmt = RecordingFormat(columns=parse_columns("id,frame,x,y"), fps=16, units="cm")
    with caplog.at_level(logging.WARNING):
        return read_resampled(path, fmt)


def test_a_recording_in_its_own_layout_is_repaired_before_it_is_resampled(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """16 fps, centimetres, id first: the glitch must not smear over the 0.4 s grid."""
    lines = [
        f"{p} {f} {100 * 1.2 * f / 16:.4f} {100 * 0.8 * p:.4f}" for f in range(64) for p in (1, 2)
    ]
    lines[40] = lines[40].split()[0] + " 20 500000 80"  # person 1 at frame 20, 5000 m
    table = read_corridor(tmp_path / "corridor.txt", lines, caplog)
    assert "line 41 (id 1, x=5000" in caplog.text
    assert np.abs(table.pos_m[:, 0]).max() < 10  # nothing near 5000 m after resampling


def no_jump_left(time_s: np.ndarray, pos_m: np.ndarray) -> bool:
    """Whether a single person's (R,) sorted times and (R, 2) positions, repaired and split
    as ``find_glitches`` says, hold no jump inside any piece."""
    found = find_glitches(np.zeros(len(time_s)), time_s, pos_m)
    piece = np.cumsum(np.isin(np.arange(len(time_s)), found.splits))[found.keep]
    t, xy = time_s[found.keep], found.pos_m[found.keep]
    speed = np.linalg.norm(np.diff(xy, axis=0), axis=1) / np.diff(t)
    return bool((speed[piece[1:] == piece[:-1]] <= MAX_JUMP_SPEED_MPS).all())


def test_a_good_row_between_two_glitches_is_never_moved_onto_them() -> None:
    """bad, good, bad: the good row's neighbours agree with each other too, so no row of the
    three is interpolated (which would put the good one at 5000 m); the jumps split."""
    time_s = np.arange(12) * 0.4
    walk = np.column_stack([1.2 * time_s, np.zeros(12)])
    for bad_rows in ([5, 7], [0, 2], [9, 11]):
        bad = walk.copy()
        bad[bad_rows, 0] = 5000.0
        found = find_glitches(np.zeros(12), time_s, bad)
        good = bad_rows[0] + 1
        assert not len(found.spikes) and found.pos_m[good, 0] == walk[good, 0]
        assert no_jump_left(time_s, bad), bad_rows
    single = walk.copy()
    single[5, 0] = 5000.0
    assert no_jump_left(time_s, single) and len(find_glitches(np.zeros(12), time_s, single))


def test_a_lasting_jump_in_a_recording_of_its_own_layout_splits_its_track(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    lines = [
        f"{p} {f} {100 * (1.2 * f / 16 + (100.0 if p == 1 and f >= 30 else 0.0)):.4f} "
        f"{100 * 0.8 * p:.4f}"
        for f in range(64)
        for p in (1, 2)
    ]
    table = read_corridor(tmp_path / "swap.txt", lines, caplog)
    assert "starts a new track" in caplog.text
    person = table.ped_id == 1
    tracks = table.track[person]
    assert len(np.unique(tracks)) == 2  # split at the jump, no 100 m step inside a track
    for track in np.unique(tracks):
        xy = table.pos_m[table.track == track]
        assert np.linalg.norm(np.diff(xy, axis=0), axis=1).max() < 1.0


def test_plot_rows_keep_the_readers_track_splits() -> None:
    """A person's earlier track (split at a jump) gets a fresh id, so that a predictor fed the
    table's rows does not join the pieces again (and warns no second time)."""
    from grouptron.data.formats.reader import table_from_values
    from grouptron.data.formats.track_files import table_rows

    rows = crowd_rows()
    rows[(rows[:, 1] == 2) & (rows[:, 0] >= 100), 2] += 50.0  # a lasting jump of id 2
    table = table_from_values(Path("t"), rows, np.arange(len(rows)), 10, check_jumps=True)
    again = table_rows(table)
    assert set(again[again[:, 0] >= 100, 1].tolist()) == {0.0, 1.0, 2.0, 3.0}
    assert again[(again[:, 0] < 100) & ~np.isin(again[:, 1], [0, 1, 3]), 1].min() >= 4.0
    assert not len(repair_rows(again, 0.04)[1])  # nothing left to repair
