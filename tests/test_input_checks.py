"""Inputs that used to end in a traceback or a silently wrong result: each now gives one
``grouptron: error:`` line (exit code 2) and leaves no output file behind, or reads correctly."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.config import DataConfig
from grouptron.data.datasets.dataset import cache_key
from grouptron.data.formats.fields import parse_numbers_fast
from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.reader import read_tracks
from grouptron.data.formats.recording import read_resampled
from grouptron.data.formats.spelling import FLAGS, KEYWORDS
from grouptron.data.formats.track_files import TrackSource, read_track_file
from grouptron.errors import GrouptronError
from grouptron.groups.labels import read_id_map
from grouptron.inference.checkpoints import resolve_checkpoint
from tests.conftest import REPO, write_tracks


def walkers(path: Path, scale: float = 1.0, skip: tuple[int, ...] = ()) -> Path:
    """Three people walking straight at 1.25 m/s (times ``scale``) for 25 steps; person 1
    misses the steps in ``skip``."""
    rows = [
        (10 * k, ped, scale * (0.5 * k), scale * (1.0 * ped))
        for k in range(25)
        for ped in (1, 2, 3)
        if not (ped == 1 and k in skip)
    ]
    return write_tracks(path, rows)


def ndjson(path: Path, track: str = "", fps: str = "2.5") -> Path:
    """A TrajNet++ file of two walkers at 0.4 s rows, with ``track`` lines appended."""
    lines = [f'{{"scene": {{"id": 0, "p": 1, "s": 0, "e": 240, "fps": {fps}}}}}']
    lines += [
        json.dumps({"track": {"f": 10 * k, "p": p, "x": 0.5 * k, "y": float(p)}})
        for k in range(25)
        for p in (1, 2)
    ]
    path.write_text("\n".join(lines) + ("\n" + track if track else "") + "\n")
    return path


def fails(argv: list[str], capsys: pytest.CaptureFixture[str], match: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    assert match in err, err
    return err


def test_ndjson_values_are_checked_and_lines_are_the_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad_x = '{"track": {"f": 250, "p": 1, "x": NaN, "y": 0.0}}'
    fails(
        ["groups", "detect", "--tracks", str(ndjson(tmp_path / "a.ndjson", bad_x))],
        capsys,
        "a.ndjson:52: x is not finite",
    )
    for fps in ("0", "-2.5"):
        path = ndjson(tmp_path / "b.ndjson", fps=fps)
        fails(["groups", "detect", "--tracks", str(path)], capsys, "b.ndjson:1: fps must be")
    half = '{"track": {"f": 250, "p": 3.5, "x": 1.0, "y": 0.0}}'
    fails(
        ["groups", "detect", "--tracks", str(ndjson(tmp_path / "c.ndjson", half))],
        capsys,
        "c.ndjson:52: p must be a whole number, not 3.5",
    )
    # The same (frame, id) at another position on the last line: both file lines are named.
    moved = '{"track": {"f": 0, "p": 1, "x": 9.0, "y": 9.0}}'
    with pytest.raises(GrouptronError, match=r"d.ndjson:52: .* \(also line 2\)"):
        read_track_file(TrackSource(ndjson(tmp_path / "d.ndjson", moved)))


def test_pictures_with_a_suffix_matplotlib_cannot_write_are_refused_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    out = tmp_path / "groups.csv"
    argv = ["groups", "detect", "--tracks", str(tracks), "--out", str(out)]
    fails([*argv, "--plot", str(tmp_path / "g.txt")], capsys, "--plot")
    fails([*argv, "--plot", str(tmp_path / "g.png"), "--frame", "105"], capsys, "not a frame")
    assert not out.exists()
    plot = ["plot", "--tracks", str(tracks), "--frame", "100", "--out", str(tmp_path / "p")]
    fails(plot, capsys, "a picture needs one of the suffixes")


def test_an_output_that_is_the_input_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_checkpoints: Path
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    before = tracks.read_text()
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--quiet"]
    fails([*argv, "--out", str(tracks)], capsys, "is an input of this command")
    fails(["groups", "detect", "--tracks", str(tracks), "--out", str(tracks)], capsys, "input")
    assert tracks.read_text() == before


def test_a_settings_section_given_as_one_value_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fails(["config", "show", "--set", "train=3"], capsys, "train must be a table of settings")
    settings = tmp_path / "settings.json"
    settings.write_text('{"train": 5}')
    fails(["config", "show", "--config", str(settings)], capsys, "not 5")


def test_default_layout_files_get_the_speed_check_and_max_gap(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    centimetres = walkers(tmp_path / "cm.txt", scale=100.0)
    fails(["groups", "detect", "--tracks", str(centimetres)], capsys, "--units cm?")
    out = tmp_path / "g.csv"
    argv = ["groups", "detect", "--tracks", str(centimetres), "--out", str(out)]
    assert main([*argv, "--no-speed-check"]) == 0
    gapped = walkers(tmp_path / "gap.txt", skip=(12,))
    # Without --max-gap an ETH/UCY-style file's gap splits the track; with it, gaps up to it
    # are bridged (person 1 is then grouped at the missing step too, interpolated there).
    for max_gap, bridged in (([], False), (["--max-gap", "0.8"], True), (["--max-gap", "2"], True)):
        argv = ["groups", "detect", "--tracks", str(gapped), "--out", str(out)]
        assert main([*argv, *max_gap]) == 0
        frames = np.loadtxt(out, delimiter=",", skiprows=1)
        assert (120 in frames[frames[:, 1] == 1, 0]) == bridged
    fails(["groups", "detect", "--tracks", str(gapped), "--max-gap", "-1"], capsys, "--max-gap")


def test_group_labels_that_match_nobody_and_bad_id_maps_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    labels = tmp_path / "labels.txt"
    labels.write_text("7 8\n")
    argv = ["groups", "evaluate", "--tracks", str(tracks), "--labels", str(labels)]
    fails(argv, capsys, "--id-map")
    labels.write_text("")
    fails(argv, capsys, "no pedestrian ids")
    labels.write_text("1 2\n")
    assert main(argv) == 0
    single = write_tracks(tmp_path / "one.txt", [(10 * k, 1, 0.5 * k, 0.0) for k in range(20)])
    argv = ["groups", "evaluate", "--tracks", str(single), "--labels", str(labels)]
    fails(argv, capsys, "no pair")
    id_map = tmp_path / "map.csv"
    for text, match in (
        ("track_id,label_id\n1,10\n1,11\n", r"map.csv:3: track 1 is mapped twice \(also line 2\)"),
        ("track_id,label_id\n1,10,5\n", "map.csv:2: expected two ids"),
        ("track_id,label_id\n", "no 'track_id,label_id' rows"),
    ):
        id_map.write_text(text)
        with pytest.raises(GrouptronError, match=match):
            read_id_map(id_map)


def test_byte_order_marks_commas_and_comments_read_alike_in_both_readers(tmp_path: Path) -> None:
    plain = walkers(tmp_path / "plain.txt")
    marked = tmp_path / "marked.txt"
    marked.write_text("\ufeff# frame id x y\n" + plain.read_text().replace("\t", ","))
    for read in (read_tracks, lambda p: read_resampled(p, RecordingFormat())):
        expected, found = read(plain), read(marked)
        np.testing.assert_array_equal(found.pos_m, expected.pos_m)
        np.testing.assert_array_equal(found.step, expected.step)
    # A typo on the first line is an error, not a header that is quietly dropped.
    typo = tmp_path / "typo.txt"
    typo.write_text(plain.read_text().replace("0.0", "O.0", 1))
    with pytest.raises(GrouptronError, match=r"typo\.txt:1: x is not a number: 'O\.0'"):
        read_resampled(typo, RecordingFormat())


def test_evaluate_refuses_what_it_cannot_score(
    synthetic_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cv = ["evaluate", "--model", "constant-velocity", "--data-dir", str(synthetic_data_dir)]
    fails([*cv, "--split", "eth", "--mode", "nll"], capsys, "needs a --checkpoint")
    fails([*cv, "--split", ""], capsys, "unknown split ''")


def test_a_mistyped_checkpoint_name_gets_a_suggestion(tiny_checkpoints: Path) -> None:
    with pytest.raises(GrouptronError, match="did you mean grouptron-eth-backward"):
        resolve_checkpoint("grouptron-eth-backwrd", tiny_checkpoints)
    with pytest.raises(GrouptronError, match=r"a folder without best\.safetensors"):
        resolve_checkpoint(tiny_checkpoints)


def test_predict_writes_to_standard_output_with_a_dash(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_checkpoints: Path
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--quiet"]
    assert main([*argv, "--out", "-"]) == 0
    printed = capsys.readouterr()
    assert main([*argv, "--out", str(tmp_path / "f.csv")]) == 0
    assert printed.out == (tmp_path / "f.csv").read_text()
    assert "to standard output" in printed.err
    assert not Path("-").exists()  # no file named "-" in the working directory


def test_a_misread_time_column_is_named_not_reported_as_duplicates(tmp_path: Path) -> None:
    tracks = tmp_path / "huge.txt"
    tracks.write_text("0 1 2 3\n1e20 1 2.4 3\n")
    with pytest.raises(GrouptronError, match=r"its times span 1e\+19 steps"):
        read_resampled(tracks, RecordingFormat())


def test_an_explicit_max_gap_keeps_the_files_own_frame_grid(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_checkpoints: Path
) -> None:
    """A file on a 12-frame grid (30 fps) read with --frames-per-step 12 and --max-gap: frames
    keep their numbers (6, 18, ...), only the missing one is added."""
    rows = [
        (6 + 12 * k, p, 0.5 * k, float(p)) for k in range(14) for p in (1, 2) if (p, k) != (1, 9)
    ]
    tracks = write_tracks(tmp_path / "grid12.txt", rows)
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    out = tmp_path / "f.csv"
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(tracks), "--quiet"]
    assert main([*argv, "--frames-per-step", "12", "--max-gap", "1", "--out", str(out)]) == 0
    frames = np.loadtxt(out, delimiter=",", skiprows=1)[:, 0]
    assert set(frames.tolist()) <= {6 + 12 * k for k in range(14)}
    walk = walkers(tmp_path / "walk.txt")
    plot = ["plot", "--checkpoint", checkpoint, "--tracks", str(walk), "--out"]
    fails([*plot, str(tmp_path / "p.png"), "--frame", "15"], capsys, "--frame 15 is not on the")


READERS = {"eth/ucy": read_tracks, "any layout": lambda p: read_resampled(p, RecordingFormat())}


@pytest.mark.parametrize("reader", READERS)
@pytest.mark.parametrize(
    ("content", "line", "why"),
    [
        ("0,1,0.0,1.0\n0,2,,5\n", 2, "an empty field in"),
        ("frame,id,x,y\n0,1,0.0,1.0\n,2,0.0,5\n", 3, "an empty field in"),
        ("0\t1\t0,5\t1,25\n10\t1\t0,9\t1,25\n", 1, "decimal commas in"),
        ("frame id x y\n0 1 0.5 1\n10 1 0,9 1\n", 3, "decimal commas in"),
        # A padding comma after a decimal comma once hid it: y was read as 1, not 1.25.
        ("0 1 2 1,25,\n10 1 2 1,5,\n", 1, "decimal commas in"),
    ],
)
def test_commas_that_would_shift_the_columns_are_refused(
    tmp_path: Path, reader: str, content: str, line: int, why: str
) -> None:
    """An empty comma-separated field, or decimal commas read as separators."""
    tracks = tmp_path / "bad.csv"
    tracks.write_text(content)
    with pytest.raises(GrouptronError, match=rf"bad\.csv:{line}: {why}"):
        READERS[reader](tracks)


@pytest.mark.parametrize("reader", READERS)
@pytest.mark.parametrize(
    "content",
    [
        "0,1,0.0,1.0,\n,,,\n10,1,0.4,1.0,,\n",  # padding commas; a line of commas is blank
        "# recorded 2020,,,\n0,1,0.0,1.0\n#,,\n10,1,0.4,1.0\n",  # commas in comments
        "frame id x y\n0\t1\t0.0\t1.0,\n10 1,0.4, 1.0\n",  # separators mixed, a header
        "0\t1\t0.0\t1.0,\n10 1,0.4, 1.0\n",  # the same without a header
    ],
)
def test_commas_that_hide_no_value_are_read(tmp_path: Path, reader: str, content: str) -> None:
    tracks = tmp_path / "commas.csv"
    tracks.write_text(content)
    table = READERS[reader](tracks)
    assert table.step.tolist() == [0, 1]
    np.testing.assert_allclose(table.pos_m, [[0.0, 1.0], [0.4, 1.0]])


def test_columns_past_the_named_ones_and_an_index_header_are_ignored(tmp_path: Path) -> None:
    """A pandas ``to_csv`` file (an unnamed index column) and empty fields past the named
    columns; the NumPy fast path still reads plain comma- and tab-separated files."""
    pandas = tmp_path / "pandas.csv"
    pandas.write_text(",frame,id,x,y\n0,0,1,0.0,1.0\n1,10,1,0.4,1.0\n")
    fmt = RecordingFormat(columns=("skip", "frame", "id", "x", "y"))
    assert read_resampled(pandas, fmt).step.tolist() == [0, 1]
    extra = tmp_path / "extra.csv"
    extra.write_text("0,1,0.0,1.0,,car\n10,1,0.4,1.0,,car\n")
    assert read_resampled(extra, RecordingFormat()).step.tolist() == [0, 1]
    for text in ("0,1,0.0,1.0\n", "0, 1, 0.0, 1.0,\n", "0\t1\t0.0\t1.0\n", "0 1 0 1 ,x\n"):
        assert parse_numbers_fast(text * 3, 4) is not None, text
    assert parse_numbers_fast("0,1,,1.0\n", 4) is None
    assert parse_numbers_fast(",1,0,1.0\n", 4) is None
    assert parse_numbers_fast("0 1 0,5 1,25\n", 4) is None  # decimal commas: the slow path refuses


def test_the_cache_key_ignores_how_messages_name_options() -> None:
    files, config = [REPO / "README.md"], DataConfig()
    keys = {cache_key(files, config, 8, RecordingFormat(spelling=s)) for s in (FLAGS, KEYWORDS)}
    assert len(keys) == 1
    assert cache_key(files, config, 8, RecordingFormat(units="cm")) not in keys


def test_both_readers_name_a_bad_number_alike(tmp_path: Path) -> None:
    tracks = tmp_path / "bad.txt"
    tracks.write_text("0 1 0.0 1.0\n10 1.5 0.4 1.0\n")
    for read in READERS.values():
        with pytest.raises(GrouptronError, match=r"bad\.txt:2: id must be a whole number, not 1.5"):
            read(tracks)
    tracks.write_text("0 1 0.0 1.0\n10 1 0.4 nan\n20 1 nan 1.0\n")
    for read in READERS.values():  # the first line at fault, whatever its column
        with pytest.raises(GrouptronError, match=r"bad\.txt:2: y is not finite"):
            read(tracks)
    # An ignored column may hold anything.
    tracks.write_text("0 1 0.0 1.0 nan\n10 1 0.4 1.0 nan\n")
    table = read_resampled(tracks, RecordingFormat(columns=("frame", "id", "x", "y", "z")))
    assert table.step.tolist() == [0, 1]


def test_evaluate_reads_a_plain_file_as_predict_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gapped = walkers(tmp_path / "gap.txt", skip=(12,))
    argv = ["evaluate", "--model", "constant-velocity", "--tracks", str(gapped), "--quiet"]
    fails([*argv, "--on-gap", "error"], capsys, "pedestrian 1 has a gap between frames 110 and 130")
    fails([*argv, "--on-gap", "error", "--max-gap", "0.5"], capsys, "longer than --max-gap 0.5 s")
    counts = {}
    for extra in ([], ["--max-gap", "0.8"]):  # split (as predict does) or bridged
        assert main([*argv, *extra, "--format", "json"]) == 0
        counts[bool(extra)] = json.loads(capsys.readouterr().out)["results"][0]["samples"]
    assert counts[False] < counts[True]


def test_named_columns_let_extra_ones_be_ignored_and_rates_are_set_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_checkpoints: Path
) -> None:
    plain = walkers(tmp_path / "walk.txt")
    wide = tmp_path / "wide.txt"
    wide.write_text("".join(line + " 1.70\n" for line in plain.read_text().splitlines()))
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    argv = ["predict", "--checkpoint", checkpoint, "--tracks", str(wide), "--quiet"]
    fails([*argv, "--out", str(tmp_path / "a.csv")], capsys, "name them with --columns")
    assert main([*argv, "--out", str(tmp_path / "b.csv"), "--columns", "frame,id,x,y"]) == 0
    rates = ["--fps", "25", "--frames-per-step", "20", "--out", str(tmp_path / "c.csv")]
    fails([*argv, *rates], capsys, "--fps and --frames-per-step both set the frame rate")
    seconds = ["--columns", "t,id,x,y", "--frames-per-step", "20", "--out", str(tmp_path / "d")]
    err = fails([*argv, *seconds], capsys, "")
    assert "--fps applies" not in err, err  # no option the user never gave is blamed


def test_options_that_would_be_ignored_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    detect = ["groups", "detect", "--tracks", str(tracks)]
    fails([*detect, "--rule", "count", "--max-distance", "0.1"], capsys, "--rule count takes")
    fails([*detect, "--rule", "count", "--velocity-weight", "5"], capsys, "--rule count takes")
    fails([*detect, "--frame", "100"], capsys, "give --plot too")
    assert main([*detect, "--max-distance", "5"]) == 0  # the threshold rule takes it
    dataset = tmp_path / "mine.toml"
    dataset.write_text(f'name = "mine"\n[parts]\ntest = ["{tracks.name}"]\n')
    evaluate = ["evaluate", "--model", "constant-velocity", "--dataset", str(dataset)]
    fails([*evaluate, "--fps", "30"], capsys, "a --dataset file gives its files' layout")
    fails([*evaluate, "--units", "cm"], capsys, "a --dataset file gives its files' layout")
    dataset.write_text('name = "mine"\n[parts]\ntest = []\n')
    fails(evaluate, capsys, "the test part lists no files")


def test_trajnet_files_with_a_missing_field_or_mixed_rates_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    detect = ["groups", "detect", "--tracks"]
    no_x = ndjson(tmp_path / "a.ndjson", '{"track": {"f": 250, "p": 1, "y": 1.0}}')
    fails([*detect, str(no_x)], capsys, "a TrajNet++ track needs f, p, x and y; 'x' is missing")
    mixed = ndjson(tmp_path / "b.ndjson", '{"scene": {"id": 1, "p": 2, "s": 0, "e": 9, "fps": 5}}')
    fails([*detect, str(mixed)], capsys, "its scenes have different fps (2.5, 5)")


def test_a_plot_frame_past_the_file_and_a_mode_named_twice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_checkpoints: Path
) -> None:
    tracks = walkers(tmp_path / "walk.txt")
    model = tiny_checkpoints / "grouptron-eth-backward"
    plot = ["plot", "--checkpoint", str(model), "--tracks", str(tracks), "--quiet"]
    fails([*plot, "--frame", "1000", "--out", str(tmp_path / "a.png")], capsys, "(0-240)")
    argv = ["evaluate", "--model", "constant-velocity", "--tracks", str(tracks), "--quiet"]
    assert main([*argv, "--mode", "ml,ml", "--format", "json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["results"]) == 2  # the file and the pool


def test_a_header_is_a_hint_to_the_layout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = [
        f"{0.1 * k:.1f},{p},{120.0 * 0.1 * k:.1f},{80.0 * p}" for k in range(40) for p in (1, 2)
    ]
    path = tmp_path / "tracker.csv"
    path.write_text("time_s,person,x_cm,y_cm\n" + "\n".join(rows) + "\n")
    err = fails(["predict", "--tracks", str(path), "--out", str(tmp_path / "f.csv")], capsys, "")
    assert "its header 'time_s,person,x_cm,y_cm' reads as --columns t,id,x,y --units cm" in err
    # ...and the hint works as written.
    argv = ["predict", "--tracks", str(path), "--columns", "t,id,x,y", "--units", "cm"]
    assert main([*argv, "--out", str(tmp_path / "f.csv"), "--min-points", "2"]) == 0


@pytest.mark.parametrize("columns", [[], ["--columns", "frame,id,x,y"]])
def test_one_message_for_a_file_that_is_not_utf8(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], columns: list[str]
) -> None:
    path = tmp_path / "latin.txt"
    path.write_bytes("0 1 1.0 2.0\n10 1 1.5 2.0 # caf\xe9\n".encode("latin-1"))
    argv = ["predict", "--tracks", str(path), *columns, "--out", str(tmp_path / "f.csv")]
    err = fails(argv, capsys, "latin.txt:2: not UTF-8 text (save the file as UTF-8")
    assert "codec" not in err


@pytest.mark.parametrize("columns", [[], ["--columns", "frame,id,x,y"]])
def test_a_name_for_an_id_is_refused_naming_the_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], columns: list[str]
) -> None:
    path = tmp_path / "named.txt"
    path.write_text("".join(f"{10 * k} ped_1 {0.5 * k} 1.0\n" for k in range(20)))
    argv = ["predict", "--tracks", str(path), *columns, "--out", str(tmp_path / "f.csv")]
    fails(argv, capsys, "id is not a number: 'ped_1' (ids must be integers")
