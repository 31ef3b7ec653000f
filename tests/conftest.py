"""Shared fixtures: synthetic track files and, where present, the real benchmark copy."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def real_data_dir() -> Path | None:
    """The ETH/UCY copy named by $GROUPTRON_DATA or beside the checkout, if it exists."""
    candidates = [os.environ.get("GROUPTRON_DATA", ""), str(REPO.parent / "shared/data/eth_ucy")]
    for candidate in candidates:
        if candidate and (Path(candidate) / "SHA256SUMS").is_file():
            return Path(candidate)
    return None


@pytest.fixture(scope="session")
def eth_ucy_dir() -> Path:
    found = real_data_dir()
    if found is None:
        pytest.skip("ETH/UCY benchmark files not available (set GROUPTRON_DATA)")
    return found


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    """Keep every test's preprocessing cache out of the user's home."""
    monkeypatch.setenv("GROUPTRON_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def write_tracks(path: Path, rows: list[tuple[float, float, float, float]]) -> Path:
    """Write ``frame id x y`` rows tab-separated, as in the benchmark files."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(f"{f}\t{i}\t{x}\t{y}\n" for f, i, x, y in rows))
    return path
