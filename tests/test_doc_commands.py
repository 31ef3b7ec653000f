"""Every documented ``grouptron`` command runs as written, top to bottom per document, on tiny
data: a sandbox holds every file the docs name (synthetic recordings in their layouts, a ROS 2
bag, a dataset description copied from the docs), every benchmark split (synthetic) and tiny
checkpoints under every shipped name. ``SKIPPED`` lists the few that do not, each with why.
The README's first three commands run in tests/test_docs.py."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli import main
from grouptron.constants import DEFAULT_CHECKPOINT, SPLITS
from tests.conftest import REPO, synthetic_recording
from tests.helpers.docs import shell_commands
from tests.helpers.ros import ODOMETRY_MSGDEF, PEOPLE_MSGDEF, odometry_message

pytest.importorskip("mcap_ros2")  # the docs' ROS 2 bag commands need the ros extra

DOCS = sorted((REPO / "docs").glob("*.md"))
HOURS = "the full 100-epoch schedule: hours on the benchmark and minutes even on tiny data"
SKIPPED = {
    "grouptron report": "scores every shipped checkpoint on the whole benchmark (8 to 36 min); "
    "tests/evaluation/test_report.py runs the report on tiny data",
    "grouptron train --split univ --derivatives central": HOURS,
    "grouptron train --split eth --model grouptron --set group_encoder.group_dim=16": HOURS,
    "grouptron train --split all-locations": HOURS,
    "grouptron train --model social-stgcnn --split eth --derivatives backward --epochs 30": "30 "
    "epochs; tests/baselines/test_learned_baselines.py trains each baseline for two on tiny data",
    "grouptron train --split univ --derivatives backward --epochs 6 --init-from "
    "runs/trajectron++-univ-central/last.safetensors": "continues the 100-epoch run skipped above",
    "grouptron evaluate --checkpoint CKPT --split univ --subset univ-45": "UNIV-45 needs the "
    "real univ test set (time steps with 45 people); the subset's own tests build one",
    "grouptron evaluate --checkpoint runs/grouptron-univ-central/best.safetensors --subset "
    "univ-45": "the same subset, of a 100-epoch run",
    "grouptron adapt --tracks monday.csv tuesday.csv": "needs 20 minutes of a site's "
    "recordings; tests/workflows/test_adapt.py adapts on two minutes",
    "grouptron predict --checkpoint runs/lobby/best.safetensors": "reads the run adapted above",
    "grouptron ros2": "joins a live ROS 2 graph until stopped; tests/ros2/test_node.py runs the "
    "node on an isolated graph",
}
"""Command prefixes not run here, each with why (their options still parse in test_docs)."""
SHIPPED = {  # shipped names the docs use -> the tiny checkpoint that stands in for each
    DEFAULT_CHECKPOINT: "grouptron-eth-backward",
    "grouptron-univ-backward": "grouptron-eth-backward",
    "grouptron-univ-central": "grouptron-eth-central",
    "trajectron++-univ-central": "trajectron++-eth-central",
    "social-stgcnn-eth-backward": "trajectron++-eth-central",  # any model: the command's path
}


def write_layout(
    path: Path, columns: str, *, fps: float = 10.0, units_per_m: float = 1.0, start_s: float = 0.0
) -> Path:
    """Six people walking for 12 s in ``columns`` (``id``, ``x``, ``y``, ``frame`` or ``t``,
    anything else a zero), sampled at ``fps``."""
    # Seeded by the file's name too: two files of one layout are two recordings, not copies
    # (a copy of a training file is refused as not held out).
    rng = np.random.default_rng(len(columns) + int(fps) + sum(map(ord, path.name)))
    lines = []
    for person in range(1, 7):
        start, velocity = rng.uniform(-4, 4, 2), rng.normal(0, 0.6, 2) + 0.6
        for frame in range(int(12 * fps)):
            t = frame / fps
            x, y = (start + velocity * t) * units_per_m
            value = {"id": person, "x": x, "y": y, "frame": frame, "t": start_s + t}
            lines.append([value.get(name, 0.0) for name in columns.split(",")])
    separator = "," if path.suffix == ".csv" else " "
    path.write_text("\n".join(separator.join(f"{v:.4f}" for v in row) for row in lines) + "\n")
    return path


@pytest.fixture
def sandbox(
    tmp_path: Path,
    tiny_checkpoints: Path,
    synthetic_data_dir: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> Path:
    data = tmp_path / "benchmark"
    for split in SPLITS:  # the synthetic recordings stand in for every location
        shutil.copytree(synthetic_data_dir / "eth", data / split)
    monkeypatch.setenv("GROUPTRON_DATA", str(data))
    shipped = tmp_path / "shipped"
    shutil.copytree(tiny_checkpoints, shipped)
    for name, tiny in SHIPPED.items():
        shutil.copytree(tiny_checkpoints / tiny, shipped / name)
        shutil.copytree(tiny_checkpoints / tiny, tmp_path / "checkpoints" / name)
    monkeypatch.setenv("GROUPTRON_CHECKPOINTS", str(shipped))
    test_file = next((synthetic_data_dir / "eth" / "test").glob("*.txt"))
    for name in ("my_tracks.txt", "biwi_eth.txt"):
        shutil.copy(test_file, tmp_path / name)
    long = synthetic_recording(tmp_path / "students003.txt", 7, pedestrians=12, steps=400)
    cached = tmp_path / ".cache" / "grouptron" / "eth_ucy" / "univ" / "test"
    cached.mkdir(parents=True)
    shutil.copy(long, cached / "students003.txt")
    monkeypatch.setenv("HOME", str(tmp_path))
    (tmp_path / "eth").mkdir()
    (tmp_path / "eth" / "groups.txt").write_text("0 1\n2 3\n")
    for name in ("corridor.txt", "uo-145-240-240.txt", "uo-180-180-180.txt", "uo-300-a.txt",
                 "uo-300-b.txt"):  # fmt: skip
        write_layout(tmp_path / name, "id,frame,x,y,z", fps=16, units_per_m=100)
    write_layout(tmp_path / "bookstore_0.txt", "frame,id,x,y", fps=30)
    for name in ("lidar.csv", "monday.csv", "tuesday.csv"):
        write_layout(tmp_path / name, "t,id,x,y", start_s=1_700_000_000.0)
    (tmp_path / "corridor.toml").write_text(_toml_block("corridor.toml"))
    write_bag(tmp_path / "run.mcap", np.loadtxt(test_file))
    shutil.copy(REPO / "examples/models/lstm_forecaster.py", tmp_path)  # docs/models.md's model
    monkeypatch.setattr(sys, "path", list(sys.path))  # a model's folder joins it while it runs
    monkeypatch.delitem(sys.modules, "lstm_forecaster", raising=False)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _toml_block(name: str) -> str:
    """The docs' TOML example that starts with ``# name``."""
    for doc in DOCS:
        for block in re.findall(r"```toml\n(.*?)```", doc.read_text(), re.S):
            if block.startswith(f"# {name}"):
                return str(block)
    raise AssertionError(f"no TOML block for {name} in docs/")


def write_bag(path: Path, rows: np.ndarray) -> None:
    """People on /people and, on /tracks, a message type grouptron does not know (docs/robots.md's
    TrackArray), one message per frame (25 fps) of (R, 4) ``frame, id, x, y`` rows; a robot's
    odometry on /odom."""
    from mcap_ros2.writer import Writer

    msgdef = (
        "std_msgs/Header header\nmy_msgs/Track[] tracks\n" + "=" * 80 + "\nMSG: std_msgs/Header\n"
        "builtin_interfaces/Time stamp\nstring frame_id\n" + "=" * 80 + "\n"
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n" + "=" * 80 + "\n"
        "MSG: my_msgs/Track\nint64 track_id\ngeometry_msgs/Pose pose\n" + "=" * 80 + "\n"
        "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\n"
        "geometry_msgs/Quaternion orientation\n" + "=" * 80 + "\nMSG: geometry_msgs/Point\n"
        "float64 x\nfloat64 y\nfloat64 z\n" + "=" * 80 + "\nMSG: geometry_msgs/Quaternion\n"
        "float64 x\nfloat64 y\nfloat64 z\nfloat64 w"
    )
    with path.open("wb") as handle:
        writer = Writer(handle)
        kinds = {
            "/people": writer.register_msgdef("people_msgs/msg/People", PEOPLE_MSGDEF),
            "/tracks": writer.register_msgdef("my_msgs/msg/TrackArray", msgdef),
            "/odom": writer.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY_MSGDEF),
        }
        for frame in np.unique(rows[:, 0]):
            now = rows[rows[:, 0] == frame]
            sec, nanosec = int(frame // 25), round((frame % 25) / 25 * 1e9)
            header = {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "map"}
            point = [{"x": float(x), "y": float(y), "z": 0.0} for *_, x, y in now]
            people_message = {"header": header, "people": [
                {"name": str(int(i)), "position": p, "velocity": {"x": 0.0, "y": 0.0, "z": 0.0},
                 "reliability": 1.0, "tagnames": [], "tags": []}
                for (_, i, *_), p in zip(now, point, strict=True)]}  # fmt: skip
            tracks = {"header": header, "tracks": [
                {"track_id": int(i), "pose": {"position": p, "orientation":
                                              {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
                for (_, i, *_), p in zip(now, point, strict=True)]}  # fmt: skip
            stamp = round(frame / 25 * 1e9)
            writer.write_message("/people", kinds["/people"], people_message, log_time=stamp)
            writer.write_message("/tracks", kinds["/tracks"], tracks, log_time=stamp)
            robot = odometry_message(frame / 25, np.zeros(3))  # a robot standing at the origin
            writer.write_message("/odom", kinds["/odom"], robot, log_time=stamp)
        writer.finish()


def _skipped(command: str) -> str | None:
    return next((why for prefix, why in SKIPPED.items() if command.startswith(prefix)), None)


@pytest.mark.slow
@pytest.mark.parametrize("doc", [d for d in DOCS if shell_commands(d)], ids=lambda d: d.name)
def test_every_documented_command_runs(doc: Path, sandbox: Path) -> None:
    tiny = str(sandbox / "shipped" / "grouptron-eth-backward" / "best.safetensors")
    ran = 0
    for command in shell_commands(doc):
        if _skipped(command):
            continue
        words = [os.path.expanduser(w) for w in shlex.split(command)[1:]]  # as the shell would
        argv = [tiny if word == "CKPT" else word for word in words]
        assert main(argv) == 0, f"{doc.name}: {command}"
        ran += 1
    assert ran, f"{doc.name}: every command skipped"


def test_every_skip_names_a_documented_command() -> None:
    """A skip whose command left the docs would hide nothing; drop it."""
    commands = [c for d in DOCS for c in shell_commands(d)]
    for prefix in SKIPPED:
        assert any(c.startswith(prefix) for c in commands), prefix
