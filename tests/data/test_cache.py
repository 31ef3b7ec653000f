"""The preprocessing cache: hit, key changes, and recovery from a damaged file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron.config import DataConfig
from grouptron.data.datasets.dataset import load_part
from tests.conftest import write_tracks


def tiny_split(root: Path) -> Path:
    for part in ("train", "val", "test"):
        rows = [(s * 10, p, 0.4 * s, float(p)) for s in range(25) for p in range(3)]
        write_tracks(root / "eth" / part / "x.txt", rows)
    return root


def cache_files(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    cache = tmp_path / "cache"
    monkeypatch.setenv("GROUPTRON_CACHE", str(cache))
    return cache


def test_second_load_reads_the_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = cache_files(monkeypatch, tmp_path)
    root = tiny_split(tmp_path / "data")
    first = load_part(root, "eth", "test", DataConfig())
    (written,) = cache.glob("eth-test-central-*.npz")
    second = load_part(root, "eth", "test", DataConfig())
    for name, value in first.samples.to_arrays().items():
        np.testing.assert_array_equal(value, second.samples.to_arrays()[name])
    assert first.scenes == second.scenes
    assert written.exists()


def test_key_follows_config_and_file_content(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = cache_files(monkeypatch, tmp_path)
    root = tiny_split(tmp_path / "data")
    load_part(root, "eth", "test", DataConfig())
    load_part(root, "eth", "test", DataConfig(derivatives="backward"))
    assert len(list(cache.glob("*.npz"))) == 2
    path = root / "eth/test/x.txt"
    path.write_text(path.read_text() + "250\t0\t10.0\t0.0\n")
    load_part(root, "eth", "test", DataConfig())
    assert len(list(cache.glob("*.npz"))) == 3


def test_damaged_cache_is_rebuilt(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = cache_files(monkeypatch, tmp_path)
    root = tiny_split(tmp_path / "data")
    expected = len(load_part(root, "eth", "test", DataConfig()).samples)
    (written,) = cache.glob("*.npz")
    written.write_bytes(b"not a zip file")
    assert len(load_part(root, "eth", "test", DataConfig()).samples) == expected


def test_cache_file_missing_an_array_is_rebuilt(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = cache_files(monkeypatch, tmp_path)
    root = tiny_split(tmp_path / "data")
    expected = len(load_part(root, "eth", "test", DataConfig()).samples)
    (written,) = cache.glob("*.npz")
    np.savez(written, unrelated=np.zeros(3))  # a readable zip of the wrong arrays
    assert len(load_part(root, "eth", "test", DataConfig()).samples) == expected
    with np.load(written) as rebuilt:
        assert "unrelated" not in rebuilt.files


def test_unwritable_cache_costs_speed_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    blocked = tmp_path / "cache"
    blocked.write_text("a file where the cache folder should be")
    monkeypatch.setenv("GROUPTRON_CACHE", str(blocked))
    root = tiny_split(tmp_path / "data")
    assert len(load_part(root, "eth", "test", DataConfig()).samples) > 0
    assert "could not write the cache file" in caplog.text
    assert "ignoring" not in caplog.text  # nothing was there to read: no damaged-file warning
