"""Malformed and adversarial tracks at every entry point: each either works or fails cleanly.

"Works" means finite output of the right shape; "fails cleanly" means exit code 2 and one
``grouptron: error:`` line naming the file (the Python API: one ``GrouptronError`` line), no
traceback and no output file, finished or temporary, left behind.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from grouptron import Predictor
from grouptron.cli import main
from grouptron.data.formats.reader import read_tracks
from grouptron.errors import GrouptronError
from tests.helpers.data import walking_tracks

SETTINGS = settings(
    max_examples=80,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


def _text(rows: np.ndarray) -> str:
    return "".join(f"{int(f)}\t{int(i)}\t{float(x)!r}\t{float(y)!r}\n" for f, i, x, y in rows)


@st.composite
def track_files(draw: st.DrawFn) -> bytes:
    """The bytes of a track file: a valid walk, then one kind of damage (or none)."""
    rows = walking_tracks(
        pedestrians=draw(st.integers(1, 5)),
        steps=draw(st.sampled_from([1, 2, 8, 9, 12, 14])),
        seed=draw(st.integers(0, 10_000)),
        speed=draw(st.sampled_from([0.0, 1.3, 10.0])),
        offset=draw(st.sampled_from([0.0, -500.0, 1e5, 3e6])),
    )
    kind = draw(
        st.sampled_from(
            [
                "valid",
                "columns",
                "text",
                "non-finite",
                "huge",
                "duplicate",
                "unsorted",
                "gap",
                "off-grid",
                "fraction",
                "empty",
                "binary",
                "crlf",
                "header",
                "blank-lines",
            ]
        )
    )
    line = draw(st.integers(0, len(rows) - 1))
    if kind == "unsorted":
        rows = rows[np.random.default_rng(line).permutation(len(rows))]
    elif kind == "duplicate":
        rows = np.vstack([rows, rows[line : line + 1]])
    elif kind == "gap" and len(rows) > 2:
        rows = np.delete(rows, line, axis=0)
    elif kind == "huge":
        rows = rows.copy()
        rows[line, 2] = draw(st.sampled_from([1e300, -1e12, 1.7e308]))
    text = _text(rows)
    lines = text.splitlines(keepends=True)
    if kind == "columns":
        lines[line] = lines[line].rstrip("\n") + draw(st.sampled_from(["\t7\n", "\n"]))
        if lines[line].count("\t") == 4:
            lines[line] = lines[line].rsplit("\t", 2)[0] + "\n"
    elif kind == "text":
        lines[line] = draw(st.sampled_from(["a b c d\n", "10 1 x 2\n", "ten 1 2 3\n"]))
    elif kind == "non-finite":
        lines[line] = f"{10 * line}\t1\t{draw(st.sampled_from(['nan', 'inf', '-inf']))}\t0\n"
    elif kind == "off-grid":
        lines[line] = f"{10 * line + 3}\t99\t1.0\t1.0\n"
    elif kind == "fraction":
        lines[line] = f"{10 * line}.5\t1\t1.0\t1.0\n"
    elif kind == "empty":
        lines = draw(st.sampled_from([[], ["\n", "  \n"]]))
    elif kind == "binary":
        return draw(st.binary(min_size=1, max_size=300))
    elif kind == "header":
        lines.insert(0, "frame\tid\tx\ty\n")
    elif kind == "blank-lines":
        lines = [*lines[:line], "\n", "\t\n", *lines[line:]]
    text = "".join(lines)
    if kind == "crlf":
        text = text.replace("\n", "\r\n")
    return text.encode()


def _run_cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


def _check_outcome(
    folder: Path,
    tracks: Path,
    out: Path,
    code: int,
    stderr: str,
    check: Callable[[Path], None],
    generated: bool = True,
) -> None:
    errors = [line for line in stderr.splitlines() if line.startswith("grouptron: error:")]
    if generated:
        event(f"exit code {code}")
    assert "Traceback" not in stderr
    if code == 0:
        assert not errors
        check(out)
    else:
        assert code == 2, stderr
        assert len(errors) == 1 and str(tracks) in errors[0], stderr
        assert not out.exists()
    assert {p.name for p in folder.iterdir()} <= {tracks.name, out.name}  # no temporaries


def _finite_csv(columns: int) -> Callable[[Path], None]:
    def check(out: Path) -> None:
        table = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
        assert table.shape[1] == columns and np.isfinite(table).all()

    return check


@given(content=track_files())
@SETTINGS
def test_reader_reads_or_names_the_file_and_line(content: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "tracks.txt"
        path.write_bytes(content)
        try:
            table = read_tracks(path)
        except GrouptronError as exc:
            message = str(exc)
            assert "\n" not in message and message.startswith(str(path))
            return
        assert np.isfinite(table.pos_m).all() and len(table.ped_id) > 0


@given(content=track_files())
@SETTINGS
def test_predict_command_writes_finite_forecasts_or_one_error_line(
    content: bytes, tiny_checkpoints: Path
) -> None:
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        tracks, out = folder / "tracks.txt", folder / "forecast.csv"
        tracks.write_bytes(content)
        argv = ["predict", "--checkpoint", str(checkpoint), "--tracks", str(tracks)]
        code, stderr = _run_cli([*argv, "--out", str(out), "--quiet"])
        _check_outcome(folder, tracks, out, code, stderr, _finite_csv(6))


@given(content=track_files())
@SETTINGS
def test_groups_detect_writes_groups_or_one_error_line(content: bytes) -> None:
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        tracks, out = folder / "tracks.txt", folder / "groups.csv"
        tracks.write_bytes(content)
        argv = ["groups", "detect", "--tracks", str(tracks), "--out", str(out)]
        code, stderr = _run_cli(argv)
        _check_outcome(folder, tracks, out, code, stderr, _finite_csv(3))


@st.composite
def track_arrays(draw: st.DrawFn) -> object:
    """What a caller might hand ``Predictor.predict``: arrays of any shape and content."""
    rows = walking_tracks(
        draw(st.integers(1, 5)),
        draw(st.sampled_from([1, 3, 9, 12])),
        draw(st.integers(0, 1000)),
        draw(st.sampled_from([0.0, 1.3, 10.0])),
        draw(st.sampled_from([0.0, 1e5])),
    )
    kind = draw(
        st.sampled_from(
            ["valid", "value", "duplicate", "shape", "strings", "empty", "list", "unsorted"]
        )
    )
    row = draw(st.integers(0, len(rows) - 1))
    if kind == "value":
        rows[row, draw(st.integers(0, 3))] = draw(
            st.sampled_from([np.nan, np.inf, -np.inf, 1e300, 0.5, -3.0, 2.0**60])
        )
    elif kind == "duplicate":
        rows = np.vstack([rows, rows[row : row + 1]])
    elif kind == "shape":
        return rows[:, : draw(st.integers(0, 3))]
    elif kind == "strings":
        return [["a", "b", "c", "d"]]
    elif kind == "empty":
        return np.zeros((0, 4))
    elif kind == "list":
        return rows.tolist()
    elif kind == "unsorted":
        rows = rows[::-1]
    return rows


@given(tracks=track_arrays())
@SETTINGS
def test_the_python_api_forecasts_or_raises_one_line(
    tracks: object, tiny_checkpoints: Path
) -> None:
    predictor = Predictor.from_checkpoint(
        "grouptron-eth-backward", checkpoints_dir=tiny_checkpoints
    )
    try:
        forecast = predictor.predict(tracks, num_samples=2)
    except GrouptronError as exc:
        event("refused")
        assert "\n" not in str(exc) and str(exc)
        return
    event(f"forecast {'some' if len(forecast) else 'nobody'}")
    assert np.isfinite(forecast.point).all()
    assert forecast.samples is not None and np.isfinite(forecast.samples).all()
    assert forecast.point.shape == (len(forecast), 12, 2)


@pytest.mark.parametrize("frames", [1, 3])
def test_ten_thousand_pedestrians_in_one_frame(
    frames: int, tiny_checkpoints: Path, tmp_path: Path
) -> None:
    tracks, out = tmp_path / "crowd.txt", tmp_path / "forecast.csv"
    rows = walking_tracks(10_000, frames, seed=0, speed=1.0, offset=0.0)
    rows[:, 2:] *= 60  # spread over ~500 m x 500 m
    tracks.write_text(_text(rows))
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    argv = ["predict", "--checkpoint", str(checkpoint), "--tracks", str(tracks)]
    code, stderr = _run_cli([*argv, "--out", str(out), "--quiet"])
    _check_outcome(tmp_path, tracks, out, code, stderr, _finite_csv(5), generated=False)
    assert code == 2  # one frame: nobody has a history; three: too many pairs at once
    groups = tmp_path / "groups.csv"
    code, stderr = _run_cli(["groups", "detect", "--tracks", str(tracks), "--out", str(groups)])
    assert code == 2 and "Traceback" not in stderr and not groups.exists(), stderr
    assert os.listdir(tmp_path) == ["crowd.txt"]


@pytest.mark.parametrize(
    ("rows", "fragment"),
    [
        # Two short tracks 10^11 steps apart: the dense per-step grids would need terabytes.
        ([(0, 1, 0, 0), (10, 1, 0.5, 0), (10**12, 2, 3, 3), (10**12 + 10, 2, 3.5, 3)], "split the"),
        # 300 people within 5 m x 5 m: a unit error, not a crowd.
        (
            [
                (frame, ped, (ped % 17) * 0.3, (ped // 17) * 0.3)
                for frame in (0, 10)
                for ped in range(300)
            ],
            "are the positions in metres?",
        ),
    ],
)
def test_recordings_too_large_or_too_dense_are_refused(
    rows: list[tuple[float, float, float, float]],
    fragment: str,
    tiny_checkpoints: Path,
    tmp_path: Path,
) -> None:
    tracks, out = tmp_path / "tracks.txt", tmp_path / "forecast.csv"
    tracks.write_text("".join(f"{f} {i} {x} {y}\n" for f, i, x, y in rows))
    checkpoint = tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors"
    argv = ["predict", "--checkpoint", str(checkpoint), "--tracks", str(tracks)]
    code, stderr = _run_cli([*argv, "--out", str(out), "--quiet"])
    _check_outcome(tmp_path, tracks, out, code, stderr, _finite_csv(5), generated=False)
    assert code == 2 and fragment in stderr
