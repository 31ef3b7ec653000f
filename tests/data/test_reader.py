"""The reader accepts the benchmark format and rejects every kind of bad input clearly."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from grouptron.data.formats.reader import read_tracks
from grouptron.errors import DataFormatError
from tests.conftest import write_tracks


def test_reads_tabs_and_spaces_sorted_by_track(tmp_path: Path) -> None:
    path = tmp_path / "mixed.txt"
    path.write_text("20 2 1.0 2.0\n10\t1\t0.5\t0.25\r\n0 1 0.0 0.0\n\n10   2   0.0  1.0\n")
    table = read_tracks(path)
    assert table.first_frame == 0
    np.testing.assert_array_equal(table.ped_id, [1, 1, 2, 2])
    np.testing.assert_array_equal(table.track, [0, 0, 1, 1])
    np.testing.assert_array_equal(table.step, [0, 1, 1, 2])
    np.testing.assert_allclose(table.pos_m, [[0, 0], [0.5, 0.25], [0, 1], [1, 2]])
    np.testing.assert_array_equal(table.frame, [0, 10, 10, 20])


def test_a_header_line_is_skipped(tmp_path: Path) -> None:
    plain = write_tracks(tmp_path / "plain.txt", [(0, 1, 0.5, 0.0), (10, 1, 1.0, 0.0)])
    header = tmp_path / "header.txt"
    header.write_text("\nframe\tid\tx\ty\n" + plain.read_text())
    np.testing.assert_array_equal(read_tracks(header).pos_m, read_tracks(plain).pos_m)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        ("frame id y x", "column 3 'y', but it is read as 'x'"),  # would mirror the scene
        ("id,frame,x,y", "column 1 'id', but it is read as 'frame'"),
    ],
)
def test_a_header_that_contradicts_the_layout_is_refused(
    tmp_path: Path, header: str, message: str
) -> None:
    plain = write_tracks(tmp_path / "plain.txt", [(0, 1, 0.5, 0.0), (10, 1, 1.0, 0.0)])
    path = tmp_path / "header.txt"
    path.write_text(header + "\n" + plain.read_text())
    with pytest.raises(DataFormatError, match=rf"header.txt:1: the header names {message}"):
        read_tracks(path)


def test_steps_count_from_first_frame(tmp_path: Path) -> None:
    table = read_tracks(write_tracks(tmp_path / "a.txt", [(780, 1, 0, 0), (790, 1, 1, 0)]))
    assert table.first_frame == 780
    np.testing.assert_array_equal(table.step, [0, 1])


@pytest.mark.parametrize(
    ("content", "line", "fragment"),
    [
        ("0 1 0.0 0.0\n10 1 0.0\n", 2, "expected 4 columns"),
        ("0 1 0.0 0.0 7\n", 1, "expected 4 columns"),
        ("0 1 0.0 0.0\n10 1 abc 0.0\n", 2, "x is not a number"),
        ("0 1 0.0 nan\n", 1, "y is not finite"),
        ("0 1 inf 0.0\n", 1, "x is not finite"),
        ("0 1 0.0 0.0\n10.5 1 0.0 0.0\n", 2, "frame must be a whole number, not 10.5"),
        ("0 1.5 0.0 0.0\n", 1, "id must be a whole number, not 1.5"),
        ("0 1 0.0 0.0\n10 1 1.0 0.0\n0 1 2.0 0.0\n", 3, "duplicate row for pedestrian 1"),
        ("0 1 0.0 0.0\n15 1 1.0 0.0\n", 2, "not on the 10-frame grid"),
        ("0 1 0.0 0.0\nframe id x y\n", 2, "frame is not a number"),  # a header only first
        ("frame id 1 2\n", 1, "frame is not a number"),
        ("0 1 2e8 0.0\n", 1, "x = 2e+08 m is out of range"),
        ("0 1 0.0 0.0\n10 1 0.0 -1e300\n", 2, "y = -1e+300 m is out of range"),
    ],
)
def test_bad_rows_name_file_and_line(
    tmp_path: Path, content: str, line: int, fragment: str
) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(content)
    with pytest.raises(DataFormatError) as info:
        read_tracks(path)
    message = str(info.value)
    assert message.startswith(f"{path}:{line}: ")
    assert fragment in message
    assert "\n" not in message
    assert info.value.line == line


@pytest.mark.parametrize(
    ("content", "fragment"),
    [("", "file is empty"), ("\n  \n\t\n", "file is empty"), (b"\x00\x01\x02", "not a text file")],
)
def test_empty_or_binary_file(tmp_path: Path, content: str | bytes, fragment: str) -> None:
    path = tmp_path / "odd.txt"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(DataFormatError, match=fragment):
        read_tracks(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DataFormatError, match="file not found"):
        read_tracks(tmp_path / "nope.txt")


def test_gap_splits_track_with_warning(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    rows = [(0, 7, 0, 0), (10, 7, 1, 0), (40, 7, 4, 0), (50, 7, 5, 0), (0, 8, 0, 1)]
    path = write_tracks(tmp_path / "gap.txt", rows)
    with caplog.at_level(logging.WARNING):
        table = read_tracks(path)
    assert "gap" in caplog.text and "pedestrian 7" in caplog.text
    np.testing.assert_array_equal(table.track, [0, 0, 1, 1, 2])
    np.testing.assert_array_equal(table.ped_id, [7, 7, 7, 7, 8])
    assert table.num_tracks == 3


def test_gap_is_an_error_on_request(tmp_path: Path) -> None:
    path = write_tracks(tmp_path / "gap.txt", [(0, 7, 0, 0), (10, 7, 1, 0), (40, 7, 4, 0)])
    with pytest.raises(DataFormatError, match="pedestrian 7 has a gap between frames 10 and 40"):
        read_tracks(path, on_gap="error")


def test_other_frame_stride(tmp_path: Path) -> None:
    path = write_tracks(tmp_path / "six.txt", [(780, 1, 0, 0), (786, 1, 1, 0), (792, 1, 2, 0)])
    np.testing.assert_array_equal(read_tracks(path, frames_per_step=6).step, [0, 1, 2])
    with pytest.raises(DataFormatError, match="10-frame grid"):
        read_tracks(path)
