"""TrajNet++ .ndjson: tracks read like any recording, forecasts written for its tools."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from grouptron.cli import main
from grouptron.data.datasets.locate import split_files
from grouptron.data.formats.reader import read_tracks
from grouptron.data.formats.track_files import TrackSource, read_track_file


def to_ndjson(txt: Path, out: Path) -> Path:
    """The ETH/UCY file as TrajNet++ lines: one scene per pedestrian, then its track rows
    (some repeated, as overlapping scenes repeat them)."""
    rows = np.loadtxt(txt)
    lines = []
    for scene_id, ped in enumerate(np.unique(rows[:, 1])):
        mine = rows[rows[:, 1] == ped]
        scene = {"id": scene_id, "p": int(ped), "s": int(mine[0, 0]), "e": int(mine[-1, 0])}
        lines.append(json.dumps({"scene": {**scene, "fps": 2.5, "tag": [1, []]}}))
    for f, p, x, y in [*rows, *rows[:5]]:
        lines.append(json.dumps({"track": {"f": int(f), "p": int(p), "x": x, "y": y}}))
    out.write_text("\n".join(lines) + "\n")
    return out


def test_ndjson_tracks_read_as_the_same_file_in_text(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    txt = split_files(synthetic_data_dir, "eth", "test")[0]
    table, _ = read_track_file(TrackSource(to_ndjson(txt, tmp_path / "scene.ndjson")))
    expected = read_tracks(txt)
    assert (table.first_frame, table.frames_per_step) == (expected.first_frame, 10)
    for name in ("ped_id", "track", "step", "pos_m"):
        np.testing.assert_array_equal(getattr(table, name), getattr(expected, name))


def test_forecasts_round_trip_through_trajnet_predictions(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    txt = split_files(synthetic_data_dir, "eth", "test")[0]
    source = to_ndjson(txt, tmp_path / "scene.ndjson")
    checkpoint = str(tiny_checkpoints / "grouptron-eth-backward" / "best.safetensors")
    common = ["predict", "--checkpoint", checkpoint, "--quiet"]
    assert main([*common, "--tracks", str(source), "--out", str(tmp_path / "out.ndjson")]) == 0
    assert main([*common, "--tracks", str(txt), "--out", str(tmp_path / "out.csv")]) == 0
    entries = [json.loads(line) for line in (tmp_path / "out.ndjson").read_text().splitlines()]
    scenes = [e["scene"] for e in entries if "scene" in e]
    predicted = [e["track"] for e in entries if "prediction_number" in e.get("track", {})]
    csv = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)  # frame,id,step,x,y,t
    csv = csv[:, :5]
    assert len(scenes) * 12 == len(predicted) == len(csv)
    by_key = {(int(f), int(p), int(k)): (x, y) for f, p, k, x, y in csv}
    for row in predicted:
        scene = scenes[row["scene_id"]]
        start = scene["e"] - 12 * 10  # the forecast's frame
        step = (row["f"] - start) // 10
        np.testing.assert_allclose((row["x"], row["y"]), by_key[(start, row["p"], step)], atol=1e-3)
        assert row["p"] == scene["p"] and row["prediction_number"] == 0
