"""A track file read at the wrong time scale, or with a layout its header contradicts, says
the likely cause and the option that fixes it, spelled as the caller spells options, beside
the original reason: each message one line."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import pytest

from grouptron.cli import main
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.recording import read_table
from grouptron.data.formats.spelling import FLAGS
from grouptron.errors import DataFormatError, GrouptronError

WALK_MPS = 1.3


def walkers(
    path: Path,
    *,
    fps: float,
    seconds: float = 10.0,
    starts: tuple[int, ...] = (0, 0, 0),
    speed_mps: float = WALK_MPS,
    time_scale: float = 1.0,
    offset: float = 0.0,
    header: str = "",
) -> Path:
    """``frame id x y`` rows, one every frame at ``fps``, of people walking side by side at
    ``speed_mps`` for ``seconds`` from their start frames; times written as ``offset + frame *
    time_scale`` (``time_scale`` 1000 / fps: milliseconds)."""
    rows = [header] if header else []
    for ped, start in enumerate(starts, start=1):
        for k in range(round(seconds * fps)):
            time = offset + (start + k) * time_scale
            written = f"{time:.0f}" if time == round(time) else f"{time:.12g}"
            rows.append(f"{written},{ped},{speed_mps * k / fps:.4f},{1.0 * ped:.1f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def evaluate(path: Path, *options: str) -> int:
    return main(["evaluate", "--model", "constant-velocity", "--tracks", str(path), *options])


def one_line(text: str) -> str:
    assert "\n" not in text.strip() and "Traceback" not in text, text
    return text


def test_a_frame_rate_too_high_names_the_likely_one_where_nobody_is_seen_long_enough(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 30 fps file read at 60 fps spans 5 s: too short to score anyone, and people walk at
    2.6 m/s. The command's own error stays; the warning before it names --fps 30."""
    path = walkers(tmp_path / "thirty.csv", fps=30)
    fmt = RecordingFormat(fps=60)
    with caplog.at_level(logging.WARNING):
        read_table(path, fmt)
    hint = "at 60 fps it spans 4.98 s and people walk at 2.6 m/s (median); if its frames are "
    hint += "at 30 fps, it spans 9.97 s and they walk at 1.3 m/s: read it with fps=30"
    said = "thirty.csv: nobody is seen for 7.6 s (8 observed and 12 future steps of 0.4 s)"
    assert f"{said}; {hint}" in one_line(caplog.text)
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        assert evaluate(path, "--columns", "frame,id,x,y", "--fps", "60") == 2
    err = capsys.readouterr().err
    assert one_line(err).startswith("grouptron: error: no pedestrian in")  # the reason stays
    assert hint.replace("fps=30", "--fps 30") in one_line(caplog.text)
    caplog.clear()
    with caplog.at_level(logging.WARNING):  # ...and the hint works as written
        assert evaluate(path, "--columns", "frame,id,x,y", "--fps", "30") == 0
    assert "nobody is seen" not in caplog.text


def test_a_frame_rate_too_high_for_walking_names_the_likely_one(tmp_path: Path) -> None:
    path = walkers(tmp_path / "fast.csv", fps=30)
    with pytest.raises(GrouptronError, match=r"walking speed is 5.2 m/s.*--fps 30$") as caught:
        read_table(path, RecordingFormat(fps=120, spelling=FLAGS))
    assert "check the units and --fps, or pass --no-speed-check" in one_line(str(caught.value))


def test_times_in_milliseconds_are_named_rather_than_left_to_fall_apart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Times in milliseconds read as seconds put a person's sightings 40 s apart: every
    track would break at --max-gap, and a long recording would be too large to process."""
    path = walkers(tmp_path / "ms.csv", fps=25, time_scale=40.0, header="t,id,x,y")
    with pytest.raises(GrouptronError) as caught:
        read_table(path, RecordingFormat(columns=("t", "id", "x", "y")))
    assert one_line(str(caught.value)).endswith(
        "ms.csv: a person's consecutive observations are 40 s apart (median), longer than "
        "max_gap_s 0.8 s, so nearly every track would break; in seconds it spans 2.77 h and "
        "people walk at 0.0013 m/s (median); times look like milliseconds, in which it spans "
        "9.96 s and they walk at 1.3 m/s: read them with columns='frame,id,x,y', fps=1000"
    )
    assert evaluate(path, "--columns", "t,id,x,y") == 2
    err = one_line(capsys.readouterr().err)
    assert "would break" in err and "read them with --columns frame,id,x,y --fps 1000" in err
    # ...and the hint works as written, the header's 't' read as frames at 1000 a second.
    assert evaluate(path, "--columns", "frame,id,x,y", "--fps", "1000") == 0


@pytest.mark.parametrize(
    ("unit", "per_second", "unix_start"),
    [("milliseconds", 1000, 1.7e12), ("microseconds", 10**6, 0.0), ("nanoseconds", 10**9, 1.7e18)],
)
def test_times_in_a_smaller_unit_read_as_the_hint_says(
    tmp_path: Path, unit: str, per_second: int, unix_start: float
) -> None:
    """Unix nanoseconds too: as frames at 10**9 a second they are beyond 2**53, so they are
    resampled onto grid steps rather than kept as frame numbers float64 cannot count."""
    stamps = walkers(tmp_path / "s.csv", fps=25, time_scale=per_second / 25, offset=unix_start)
    seconds = RecordingFormat(columns=("t", "id", "x", "y"), spelling=FLAGS)
    fix = f"read them with --columns frame,id,x,y --fps {per_second}"
    with pytest.raises(GrouptronError, match=rf"times look like {unit}, in which .*: {fix}$"):
        read_table(stamps, seconds)
    table = read_table(stamps, RecordingFormat(fps=per_second))
    assert table.num_tracks == 3 and len(table.step) == 3 * 25


def test_a_frame_rate_too_low_is_named_rather_than_split_the_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A file numbered at 25 fps read with --fps 2.5 (the steps per second) stretches a day
    of 60 short walks tenfold: far too many steps for one scene."""
    starts = tuple(range(0, 2_400_000, 40_000))
    path = walkers(tmp_path / "day.csv", fps=25, seconds=1.0, starts=starts)
    fmt = RecordingFormat(fps=2.5, spelling=FLAGS)
    with pytest.raises(GrouptronError) as caught:
        read_table(path, fmt)
    message = one_line(str(caught.value))
    assert message.endswith(
        "day.csv: 60 people over 2,360,025 steps of 0.4 s is too large to process at once; at "
        "2.5 fps it spans 10.9 days and people walk at 0.13 m/s (median); if its frames are at "
        "25 fps, it spans 26.2 h and they walk at 1.3 m/s: read it with --fps 25"
    )
    assert "split the recording" not in message
    assert evaluate(path, "--columns", "frame,id,x,y", "--fps", "2.5") == 2
    assert "read it with --fps 25" in one_line(capsys.readouterr().err)
    read_table(path, dataclasses.replace(fmt, fps=25.0))  # as the hint says: it reads


def test_usual_and_slow_recordings_read_without_a_time_hint(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """No hint where the times are right: people at 1.3 m/s, a slow crowd at 0.2 m/s (as in
    the Stanford Drone bookstore), a short recording at a usual pace."""
    for speed, seconds in ((WALK_MPS, 10.0), (0.2, 20.0), (WALK_MPS, 3.0)):
        path = walkers(tmp_path / "usual.csv", fps=25, seconds=seconds, speed_mps=speed)
        with caplog.at_level(logging.WARNING):
            read_table(path, RecordingFormat(fps=25))
        assert "fps" not in caplog.text, (speed, seconds)


def test_an_id_first_header_names_the_columns_it_implies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A header ``person,time_s,x_m,y_m`` read with the default columns (frame, id, x, y) is
    refused at its first line, naming the columns it reads as: as the command line spells
    them with or without --columns or --fps, as Python spells them for the library."""
    rows = [f"{ped},{0.4 * k:.1f},{0.5 * k:.1f},{1.0 * ped}" for ped in (1, 2) for k in range(25)]
    path = tmp_path / "tracker.csv"
    path.write_text("person,time_s,x_m,y_m\n" + "\n".join(rows) + "\n")
    said = r"tracker.csv:1: the header names column 1 'person' \(id\), but it is read as 'frame'"
    with pytest.raises(DataFormatError, match=said + r".*reads as columns='id,t,x,y'$"):
        read_table(path, RecordingFormat())
    implied = "its header 'person,time_s,x_m,y_m' reads as --columns id,t,x,y"
    for options in ([], ["--columns", "frame,id,x,y"], ["--fps", "25"]):
        assert evaluate(path, *options) == 2
        err = one_line(capsys.readouterr().err)
        assert "the header names column 1 'person' (id)" in err and err.strip().endswith(implied)
    assert evaluate(path, "--columns", "id,t,x,y") == 0  # ...and the hint works as written
