"""Recordings of any layout, frame rate, time base and units, resampled to the 0.4 s step."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.config import DataConfig
from grouptron.data.formats.layout import RecordingFormat, parse_columns
from grouptron.data.formats.reader import read_tracks
from grouptron.data.formats.recording import read_recording, read_resampled
from grouptron.data.formats.spelling import FLAGS
from grouptron.data.formats.track_files import TrackSource, load_tracks
from grouptron.errors import DataFormatError, GrouptronError
from grouptron.evaluation.evaluate import constant_velocity_scores
from grouptron.evaluation.recordings import recording_samples
from tests.conftest import REPO

OOD = REPO.parent / "shared" / "data" / "ood"


def curving_people(duration_s: float = 14.0) -> dict[int, tuple[float, float, callable]]:
    """Three walkers on smooth curves (constant velocity is wrong on them): id -> (start, end,
    position(t) in metres)."""

    def walker(x0: float, y0: float, vx: float, turn: float):
        return lambda t: np.stack([x0 + vx * t, y0 + 0.6 * np.sin(turn * t) + 0.1 * t], axis=-1)

    return {
        1: (0.0, duration_s, walker(0.0, 0.0, 1.2, 0.5)),
        2: (1.1, duration_s, walker(2.0, 3.0, -0.9, 0.8)),
        7: (0.3, duration_s - 2.0, walker(-3.0, 1.0, 1.0, 0.3)),
    }


def write_recording(
    path: Path,
    times_s: np.ndarray,
    *,
    columns: str,
    scale: float = 1.0,
    fps: float | None = None,
    sep: str = " ",
    header: bool = False,
) -> Path:
    """Write the walkers sampled at ``times_s`` in the given column layout."""
    rows = []
    for ped, (start, end, position) in curving_people().items():
        t = times_s[(times_s >= start - 1e-9) & (times_s <= end + 1e-9)]
        xy = position(t) * scale
        for ti, (x, y) in zip(t, xy, strict=True):
            fields = {"id": f"{ped}", "x": f"{x:.6f}", "y": f"{y:.6f}", "z": "1.70", "-": "0"}
            fields["frame"] = f"{round(ti * fps)}" if fps else ""
            fields["t"] = f"{ti + 1.7e9:.6f}"  # Unix-like seconds
            rows.append(sep.join(fields[c] for c in columns.split(",")))
    text = (sep.join(columns.split(",")) + "\n" if header else "") + "\n".join(rows) + "\n"
    path.write_text(text)
    return path


def cv_fde(path: Path, fmt: RecordingFormat) -> np.ndarray:
    samples = recording_samples([TrackSource.from_format(path, fmt)], DataConfig())
    return constant_velocity_scores(samples, 12).fde


@pytest.mark.parametrize(
    ("rate", "columns", "fps"),
    [
        (10.0, "frame,id,x,y", 10.0),
        (16.0, "id,frame,x,y,z", 16.0),
        (29.97, "frame,id,x,y", 29.97),
        (7.0, "t,id,x,y", None),  # seconds, 7 Hz
    ],
)
def test_constant_velocity_at_the_native_rate_equals_it_on_a_file_resampled_beforehand(
    tmp_path: Path, rate: float, columns: str, fps: float | None
) -> None:
    times = np.arange(0.0, 14.0 + 1e-9, 1.0 / rate)
    native = write_recording(tmp_path / "native.txt", times, columns=columns, fps=fps)
    fmt = RecordingFormat(columns=parse_columns(columns), fps=fps)
    # The same tracks resampled by hand onto 0.4 s from the recording's first time, written
    # as an ETH/UCY file (10 frames per step).
    recording = read_recording(native, fmt)
    start = recording.time_s.min()
    rows = []
    for ped in np.unique(recording.ped_id):
        mine = recording.ped_id == ped
        t, xy = recording.time_s[mine], recording.pos_m[mine]
        k = np.arange(
            np.ceil((t.min() - start) / 0.4 - 1e-9), np.floor((t.max() - start) / 0.4 + 1e-9) + 1
        )
        grid = start + 0.4 * k
        rows += [
            f"{int(kk) * 10} {ped} {float(np.interp(g, t, xy[:, 0]))!r} "
            f"{float(np.interp(g, t, xy[:, 1]))!r}"
            for kk, g in zip(k, grid, strict=True)
        ]
    by_hand = tmp_path / "by_hand.txt"
    by_hand.write_text("\n".join(rows) + "\n")
    ours, theirs = cv_fde(native, fmt), cv_fde(by_hand, RecordingFormat())
    assert len(ours) == len(theirs) > 20
    np.testing.assert_allclose(ours, theirs, atol=1e-6)
    assert ours.mean() > 0.05  # the curves make constant velocity wrong: a real comparison


def test_eth_ucy_layout_is_read_exactly_as_the_benchmark_reader(tmp_path: Path) -> None:
    times = np.arange(0.0, 14.0, 0.4)
    path = write_recording(tmp_path / "eth.txt", times, columns="frame,id,x,y", fps=25.0)
    expected = read_tracks(path)
    table = read_resampled(path, RecordingFormat())
    assert (table.first_frame, table.frames_per_step) == (expected.first_frame, 10)
    for name in ("ped_id", "track", "step", "pos_m"):
        np.testing.assert_array_equal(getattr(table, name), getattr(expected, name))


def test_resampling_interpolates_inside_tracks_and_never_extrapolates(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    # One person seen at 0.0, 0.5, 1.0 s (x = 0, 1, 2 m) and at 2.8 s (a 1.8 s gap: split).
    path.write_text("0.0 1 0 0\n0.5 1 1 0\n1.0 1 2 0\n2.8 1 5.6 0\n")
    table = read_resampled(path, RecordingFormat(columns=("t", "id", "x", "y")))
    np.testing.assert_allclose(table.pos_m[:, 0], [0.0, 0.8, 1.6, 5.6])  # 0, 0.4, 0.8; 2.8 s
    np.testing.assert_array_equal(table.step, [0, 1, 2, 7])
    assert table.num_tracks == 2  # no grid point between 1.0 s and 2.8 s was invented
    bridged = read_resampled(path, RecordingFormat(columns=("t", "id", "x", "y"), max_gap_s=2.5))
    assert bridged.num_tracks == 1
    np.testing.assert_array_equal(bridged.step, np.arange(8))
    np.testing.assert_allclose(bridged.pos_m[3:7, 0], [2.4, 3.2, 4.0, 4.8])  # across the gap


def test_units_headers_commas_and_extra_columns(tmp_path: Path) -> None:
    times = np.arange(0.0, 8.0, 0.1)
    metres = write_recording(tmp_path / "m.txt", times, columns="t,id,x,y")
    mm = write_recording(
        tmp_path / "mm.csv", times, columns="id,t,x,y,z", scale=1000.0, sep=",", header=True
    )
    a = read_resampled(metres, RecordingFormat(columns=("t", "id", "x", "y")))
    b = read_resampled(mm, RecordingFormat(columns=("id", "t", "x", "y"), units="mm"))
    np.testing.assert_allclose(a.pos_m, b.pos_m, atol=1e-5)


def test_a_header_is_checked_against_the_columns_only_where_it_names_known_ones(
    tmp_path: Path,
) -> None:
    times = np.arange(0.0, 8.0, 0.1)
    path = write_recording(tmp_path / "h.csv", times, columns="id,t,y,x,z", sep=",", header=True)
    with pytest.raises(DataFormatError, match=r"h.csv:1: .*column 3 'y', but it is read as 'x'"):
        read_resampled(path, RecordingFormat(columns=("id", "t", "x", "y")))
    swapped = read_resampled(path, RecordingFormat(columns=("id", "t", "y", "x")))
    own = tmp_path / "own.csv"  # names the layout does not know are not judged
    own.write_text("track,time,py,px,height\n" + path.read_text().split("\n", 1)[1])
    unjudged = read_resampled(own, RecordingFormat(columns=("id", "t", "y", "x")))
    np.testing.assert_array_equal(swapped.pos_m, unjudged.pos_m)


def test_a_file_in_centimetres_is_refused_with_the_units_hint(tmp_path: Path) -> None:
    times = np.arange(0.0, 8.0, 1 / 16)
    path = write_recording(tmp_path / "cm.txt", times, columns="id,frame,x,y", scale=100.0, fps=16)
    fmt = RecordingFormat(columns=("id", "frame", "x", "y"), fps=16)
    with pytest.raises(GrouptronError, match=r"median walking speed is .* m/s.*units='cm'"):
        read_resampled(path, fmt)
    with pytest.raises(GrouptronError, match=r"--units cm\?\) and --fps, or pass --no-speed"):
        read_resampled(path, dataclasses.replace(fmt, spelling=FLAGS))
    with pytest.raises(GrouptronError, match=r"and fps, or pass check_speed=False to go on"):
        load_tracks(path, columns="id,frame,x,y", fps=16)
    forced = RecordingFormat(columns=("id", "frame", "x", "y"), fps=16, check_speed=False)
    assert len(read_resampled(path, forced).step) > 0  # an explicit flag lets an expert go on


@pytest.mark.parametrize(
    ("columns", "fps", "units", "message"),
    [
        (("frame", "x", "y"), None, "m", "exactly one 'id'"),
        (("frame", "t", "id", "x", "y"), None, "m", "one time column"),
        (("id", "x", "y"), None, "m", "one time column"),
        (("t", "id", "x", "y"), 30.0, "m", "{fps} applies to a 'frame' column"),
        (("frame", "id", "x", "y"), -4.0, "m", "{fps} must be a positive number"),
        (("frame", "id", "x", "y"), None, "inch", "{units} must be one of"),
    ],
)
def test_bad_formats_are_refused_in_one_line(
    columns: tuple[str, ...], fps: float | None, units: str, message: str
) -> None:
    """Options are named as the caller wrote them: keywords, or the command line's flags."""
    with pytest.raises(GrouptronError, match=message.format(fps="^fps", units="^units")):
        RecordingFormat(columns=columns, fps=fps, units=units)
    with pytest.raises(GrouptronError, match=message.format(fps="--fps", units="--units")):
        RecordingFormat(columns=columns, fps=fps, units=units, spelling=FLAGS)
    with pytest.raises(GrouptronError, match=message.format(fps="^fps", units="^units")):
        load_tracks("unread.txt", columns=columns, fps=fps, units=units)


def test_bad_rows_name_the_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.txt"
    path.write_text("0 1 0 0\n10 1 0.4 0\n20 1 oops 0\n")
    with pytest.raises(DataFormatError, match=r":3: x is not a number: .oops."):
        read_resampled(path, RecordingFormat())
    path.write_text("0 1 0 0\n10 1 0.4\n")
    with pytest.raises(DataFormatError, match=r":2: 3 columns, but 4 column names were given"):
        read_resampled(path, RecordingFormat())
    path.write_text("0 1 0 0\n0 1 0.4 0\n")
    with pytest.raises(DataFormatError, match="two rows for pedestrian 1"):
        read_resampled(path, RecordingFormat())


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--columns", "frame,x,y"], "--columns frame,x,y: needs"),
        (["--columns", "t,id,x,y", "--fps", "30"], "--fps applies"),
        (["--units", "inch"], "--units"),
        (["--max-gap", "0"], "--max-gap must be"),
        (["--fps", "nan"], "--fps must be"),
    ],
)
def test_the_command_line_refuses_bad_reader_options_with_exit_2(
    tmp_path: Path, argv: list[str], named: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_recording(
        tmp_path / "r.txt", np.arange(0, 10, 0.4), columns="frame,id,x,y", fps=25
    )
    command = ["evaluate", "--model", "constant-velocity", "--tracks", str(path), *argv]
    assert main(command) == 2
    err = capsys.readouterr().err
    assert err.startswith(("grouptron: error:", "usage:")) and "Traceback" not in err
    assert named in err  # options named as the flags given


@pytest.mark.realdata
@pytest.mark.skipif(not OOD.is_dir(), reason="the out-of-domain recordings are not beside the repo")
def test_out_of_domain_recordings_load_with_one_command_each(
    capsys: pytest.CaptureFixture[str],
) -> None:
    hermes = str(OOD / "hermes_corridor_1d" / "uo-145-240-240.txt")
    common = ["evaluate", "--model", "constant-velocity", "--format", "json", "--tracks"]
    layout = ["--columns", "id,frame,x,y,z", "--fps", "16"]
    assert main([*common, hermes, *layout]) == 2
    assert "--units cm" in capsys.readouterr().err
    assert main([*common, hermes, *layout, "--units", "cm"]) == 0
    assert '"samples": 1165' in capsys.readouterr().out
    sdd = str(OOD / "trajnet_sdd" / "bookstore_0.txt")
    assert main([*common, sdd, "--fps", "30"]) == 0
    assert '"split": "bookstore_0.txt"' in capsys.readouterr().out


def test_groups_and_plot_read_recordings_in_their_own_layout(
    tmp_path: Path, tiny_checkpoints: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`groups detect` and `plot` take the same layout options as `evaluate --tracks`: a 16 fps
    centimetre file gives the groups of the same walkers written ETH/UCY-style."""
    times = np.arange(0, 14.0, 1 / 16)
    native = write_recording(tmp_path / "cm.txt", times, columns="id,frame,x,y", scale=100, fps=16)
    grid = write_recording(
        tmp_path / "eth.txt", np.arange(0, 14.0, 0.4), columns="frame,id,x,y", fps=25
    )
    layout = ["--columns", "id,frame,x,y", "--fps", "16", "--units", "cm"]
    outputs = []
    for args in ([str(grid)], [str(native), *layout]):
        out = tmp_path / f"groups{len(outputs)}.csv"
        assert main(["groups", "detect", "--tracks", *args, "--out", str(out)]) == 0
        outputs.append(np.loadtxt(out, delimiter=",", skiprows=1))
    # Same people, same groups at the same times (a 0.4 s step is 10 frames at 25 fps, and the
    # 16 fps file's steps are counted from its first row: both start at time 0).
    assert len(outputs[0]) == len(outputs[1]) > 0
    np.testing.assert_array_equal(outputs[0][:, 1:], outputs[1][:, 1:])
    assert (
        main(
            [
                "groups",
                "detect",
                "--tracks",
                str(native),
                "--columns",
                "id,frame,x,y",
                "--fps",
                "16",
            ]
        )
        == 2
    )
    assert "--units" in capsys.readouterr().err  # centimetres read as metres: refused
    picture = tmp_path / "plot.png"
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    assert main(["plot", "--checkpoint", checkpoint, "--tracks", str(native), *layout,
                 "--frame", "20", "--samples", "2", "--out", str(picture)]) == 0  # fmt: skip
    assert picture.stat().st_size > 1000  # 16 fps is no whole number of frames per step:
    # --frame counts 0.4 s steps from the first row (step 20 = 8 s)


def test_the_python_api_reads_any_layout_for_the_predictor(
    tmp_path: Path, tiny_checkpoints: Path
) -> None:
    from grouptron import Predictor, load_tracks

    native = write_recording(
        tmp_path / "cm.txt", np.arange(0, 14.0, 1 / 16), columns="id,frame,x,y", scale=100, fps=16
    )
    grid = write_recording(
        tmp_path / "eth.txt", np.arange(0, 14.0, 0.4), columns="frame,id,x,y", fps=25
    )
    rows = load_tracks(native, columns="id,frame,x,y", fps=16, units="cm")
    expected = load_tracks(grid, fps=25)  # already on the grid: the same rows
    order = np.lexsort((rows[:, 0], rows[:, 1]))
    by_id = np.lexsort((expected[:, 0], expected[:, 1]))
    np.testing.assert_allclose(rows[order], expected[by_id], atol=1e-3)  # interpolation error
    predictor = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    forecast = predictor.predict(rows, t=200)
    assert len(forecast) == 3 and np.isfinite(forecast.point).all()
    with pytest.raises(GrouptronError, match=r"units='cm'"):
        load_tracks(native, columns="id,frame,x,y", fps=16)


def test_density_bins_and_ablations_reach_recordings_and_datasets(
    tmp_path: Path, tiny_checkpoints: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--by-density` and `--ablate` act on `--tracks` and `--dataset` as on the benchmark
    (they were once ignored there without a word)."""
    path = write_recording(
        tmp_path / "walk.txt", np.arange(0, 14.0, 0.4), columns="frame,id,x,y", fps=25
    )
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward")
    common = ["evaluate", "--checkpoint", checkpoint, "--format", "json", "--quiet"]
    rows = {}
    for ablate in ([], ["--ablate", "edges,scene"]):
        argv = [*common, "--tracks", str(path), "--by-density", *ablate]
        assert main(argv) == 0
        scored = json.loads(capsys.readouterr().out)["results"]
        assert {r["samples"] for r in scored if r["model"] == "constant-velocity"}  # beside it
        rows[bool(ablate)] = [r for r in scored if r["model"] != "constant-velocity"]
    bins = [r for r in rows[False] if r["subset"]]
    pooled = next(r for r in rows[False] if r["split"] == "all files" and not r["subset"])
    assert bins and all(r["subset"].startswith("neighbours ") for r in bins)
    assert sum(r["samples"] for r in bins) == pooled["samples"]  # every sample in one bin
    assert {r["model"] for r in rows[True]} == {"grouptron without edges and scene"}
    assert rows[True][0]["fde"] != rows[False][0]["fde"]
    (tmp_path / "mine.toml").write_text(
        f'name = "mine"\n[format]\ncolumns = "frame,id,x,y"\n[parts]\ntest = ["{path.name}"]\n'
    )
    argv = [*common, "--dataset", str(tmp_path / "mine.toml"), "--by-density"]
    assert main([*argv, "--ablate", "scene"]) == 0
    got = json.loads(capsys.readouterr().out)["results"]
    assert got[0]["subset"] is None and got[0]["samples"] == pooled["samples"]
    assert {r["model"] for r in got} == {"grouptron without scene", "constant-velocity"}
    assert len(got) > 2
