"""``grouptron plot``: pictures of one or two models' forecasts at a frame, and animations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grouptron.cli import main


def test_plot_draws_one_panel_per_model_and_refuses_an_empty_frame(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    tracks = next((synthetic_data_dir / "eth/test").glob("*.txt"))
    frames = np.loadtxt(tracks)[:, 0]
    a = str(tiny_checkpoints / "trajectron++-eth-central/best.safetensors")
    b = str(tiny_checkpoints / "grouptron-eth-backward/best.safetensors")
    out = tmp_path / "plot.png"
    argv = ["plot", "--checkpoint", a, "--tracks", str(tracks), "--samples", "3"]
    assert (
        main([*argv, "--compare", b, "--frame", str(int(frames.max()) - 50), "--out", str(out)])
        == 0
    )
    assert out.read_bytes()[:4] == b"\x89PNG"
    mean = tmp_path / "mean.png"  # another point forecast, drawn where the ml one was
    at = ["--compare", b, "--frame", str(int(frames.max()) - 50), "--forecast", "mean"]
    assert main([*argv, *at, "--out", str(mean)]) == 0
    assert mean.read_bytes()[:4] == b"\x89PNG" and mean.read_bytes() != out.read_bytes()
    assert main([*argv, "--frame", str(int(frames.min())), "--out", str(tmp_path / "x.png")]) == 2
    assert not (tmp_path / "x.png").exists()


def test_plot_draws_regions_by_default_and_ids_when_asked(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    tracks = next((synthetic_data_dir / "eth/test").glob("*.txt"))
    b = str(tiny_checkpoints / "grouptron-eth-backward")
    argv = ["plot", "--checkpoint", b, "--tracks", str(tracks), "--quiet"]
    pictures = {}
    for name, extra in {
        "regions": [],
        "wider": ["--region", "0.5"],
        "ids": ["--ids"],
        "bare": ["--region", "0"],
    }.items():
        pictures[name] = tmp_path / f"{name}.png"
        assert main([*argv, *extra, "--out", str(pictures[name])]) == 0
    drawn = {name: path.read_bytes() for name, path in pictures.items()}
    assert len(set(drawn.values())) == 4  # each option changes the picture
    assert main([*argv, "--region", "0.5,0.9", "--out", str(tmp_path / "x.png")]) == 2


def test_plot_animates_a_range_of_frames_as_a_gif(
    tiny_checkpoints: Path, synthetic_data_dir: Path, tmp_path: Path
) -> None:
    from PIL import Image

    tracks = next((synthetic_data_dir / "eth/test").glob("*.txt"))
    frames = np.loadtxt(tracks)[:, 0]
    first = int(np.median(frames))
    a = str(tiny_checkpoints / "grouptron-eth-backward/best.safetensors")
    argv = ["plot", "--checkpoint", a, "--tracks", str(tracks), "--samples", "2", "--quiet"]
    out = tmp_path / "forecast.gif"
    assert main([*argv, "--frame", str(first), "--until", str(first + 30), "--out", str(out)]) == 0
    with Image.open(out) as movie:
        assert movie.n_frames == 4  # frames first, +10, +20, +30
    for bad_out, until in (("a.png", first + 30), ("b.gif", first - 10)):
        code = main(
            [*argv, "--frame", str(first), "--until", str(until), "--out", str(tmp_path / bad_out)]
        )
        assert code == 2
        assert not (tmp_path / bad_out).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["forecast.gif"]  # no temporary left
