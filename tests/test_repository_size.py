"""The repository holds the product, not the lab: a guard on what git tracks.

Training state (``last.safetensors``, ``candidates/``) and run folders never enter the tree;
weights live only in ``checkpoints/<name>/best.safetensors``, the group detector's
``src/grouptron/groups/detector/best.safetensors`` and the test fixtures; no file is
above 2 MB and the tree stays small. The one exception is a paused run's state in
``campaign/paused/`` (committed once when its training pauses, deleted by the commit that ships
or drops it; campaign/README.md, "Training state"), bounded on its own.
"""

from __future__ import annotations

import fnmatch
import subprocess
from pathlib import Path

import pytest

from tests.conftest import REPO

MB = 1_000_000
TREE_LIMIT_BYTES = 60 * MB
FILE_LIMIT_BYTES = 2 * MB
PAUSED_LIMIT_BYTES = 30 * MB
WEIGHTS = (
    "checkpoints/*/best.safetensors",
    "src/grouptron/groups/detector/best.safetensors",  # a pair classifier, not a forecaster
    "tests/golden/*.safetensors",
)
PAUSED = "campaign/paused/"


def _matches(path: str, patterns: tuple[str, ...]) -> bool:
    return any(fnmatch.fnmatch(path, pattern) for pattern in patterns)


def violations(sizes: dict[str, int]) -> list[str]:
    """Every broken rule of a tracked tree given as {path: bytes}; empty when it is lean."""
    found = []
    paused = {p: n for p, n in sizes.items() if p.startswith(PAUSED)}
    product = {p: n for p, n in sizes.items() if p not in paused}
    for path, size in sizes.items():
        if size > FILE_LIMIT_BYTES:
            found.append(
                f"{path}: {size / MB:.1f} MB, above the {FILE_LIMIT_BYTES / MB:.0f} MB limit"
            )
    for path in product:
        state = path.endswith("last.safetensors") or "/candidates/" in f"/{path}"
        if state:
            found.append(f"{path}: training state (campaign/README.md, 'Training state')")
        elif path.startswith(("campaign/runs/", "campaign/screen/")):
            found.append(f"{path}: a run folder (keep its records in campaign/records/)")
        elif path.endswith(".safetensors") and not _matches(path, WEIGHTS):
            found.append(f"{path}: weights outside checkpoints/*/best.safetensors")
    if sum(product.values()) > TREE_LIMIT_BYTES:
        found.append(f"tracked tree {sum(product.values()) / MB:.1f} MB, above 60 MB")
    if sum(paused.values()) > PAUSED_LIMIT_BYTES:
        found.append(f"{PAUSED}: {sum(paused.values()) / MB:.1f} MB of paused state, above 30 MB")
    return found


def tracked_sizes(repo: Path) -> dict[str, int]:
    """{path: bytes} of every file git tracks in ``repo`` (as checked out)."""
    listing = subprocess.run(
        ["git", "ls-files", "-z"], cwd=repo, capture_output=True, check=True
    ).stdout.decode()
    paths = [p for p in listing.split("\0") if p]
    return {p: (repo / p).stat().st_size for p in paths if (repo / p).is_file()}


@pytest.fixture(scope="module")
def sizes() -> dict[str, int]:
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    return tracked_sizes(REPO)


def test_the_tracked_tree_is_the_product(sizes: dict[str, int]) -> None:
    assert violations(sizes) == []


def test_the_guard_fails_on_training_state_run_folders_and_growth(
    sizes: dict[str, int],
) -> None:
    added = {
        "checkpoints/trajectron++-univ-backward/last.safetensors": 1_700_000,
        "campaign/runs/x/last.safetensors": 1_700_000,
        "checkpoints/x/candidates/epoch-003.safetensors": 500_000,
        "campaign/runs/x/metrics.jsonl": 1_000,
        "src/grouptron/weights.safetensors": 500_000,
        "data/big.csv": 3 * MB,
    }
    found = violations({**sizes, **added})
    for path in added:
        assert any(line.startswith(path) for line in found), path
    grown = {**sizes, **{f"src/grouptron/model_{i}.bin": 1_500_000 for i in range(41)}}
    assert any(line.startswith("tracked tree") for line in violations(grown))
    assert violations({**sizes, "campaign/paused/r/last.safetensors": 1_700_000}) == []
