"""Shipped checkpoints are portable: no file under ``checkpoints/`` names an absolute path of
the machine a model was trained on (a dataset description is named relative to the
repository, ``campaign/ship.py``), in its text files or in the metadata of its weights."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from tests.conftest import REPO

SHIPPED = REPO / "checkpoints"
TEXT = (".json", ".jsonl", ".csv", ".md", ".txt", ".toml")
ABSOLUTE = re.compile(
    r"""(?:^|(?<=[\s"'`(\[=,;:]))/[\w.~+-][^\s"'`)\]\\,;]*"""  # /work/main/...
    r"""|(?<![\w])[A-Za-z]:(?:\\\\|\\|/)\w[^\s"'`)\],;]*""",  # C:\Users\..., C:/...
    re.MULTILINE,
)


def safetensors_metadata(path: Path) -> dict[str, str]:
    """The string metadata of a safetensors file, read from its header alone (not its tensors)."""
    with path.open("rb") as handle:
        size = int.from_bytes(handle.read(8), "little")
        header = json.loads(handle.read(size))
    return header.get("__metadata__") or {}


def absolute_paths(text: str) -> list[str]:
    """Every absolute path (POSIX, or Windows with a drive) that ``text`` names."""
    return [match.group(0) for match in ABSOLUTE.finditer(text)]


def shipped_texts() -> list[tuple[str, str]]:
    """(where, text) for every text file under ``checkpoints/`` and every metadata value of its
    weights."""
    found = []
    for path in sorted(SHIPPED.rglob("*")):
        where = str(path.relative_to(REPO))
        if path.suffix in TEXT:
            found.append((where, path.read_text()))
        elif path.suffix == ".safetensors":
            metadata = safetensors_metadata(path)
            found += [(f"{where} (metadata {key!r})", value) for key, value in metadata.items()]
    return found


@pytest.mark.parametrize(
    ("text", "paths"),
    [
        (
            '"dataset": "/work/main/campaign/deployment/x.toml"',
            ["/work/main/campaign/deployment/x.toml"],
        ),
        ('`dataset = "/home/me/corridor.toml"`', ["/home/me/corridor.toml"]),
        ("a dataset of your own, `/data/c.toml`)", ["/data/c.toml"]),
        ('{"init_from":"/tmp/best.safetensors"}', ["/tmp/best.safetensors"]),
        ('"dataset": "C:\\\\Users\\\\me\\\\c.toml"', ["C:\\\\Users\\\\me\\\\c.toml"]),
        ("D:/data/c.toml", ["D:/data/c.toml"]),
        ('"dataset": "campaign/deployment/x.toml", "init_from": ""', []),
        ("speed in m/s, ADE/FDE, relative to now / 1 m, see https://example.org/a", []),
        ("`checkpoints/x/best.safetensors`, */best.safetensors, c.toml#sha256=ab", []),
    ],
)
def test_absolute_paths_are_recognised(text: str, paths: list[str]) -> None:
    assert absolute_paths(text) == paths


def test_no_shipped_file_names_an_absolute_path() -> None:
    texts = shipped_texts()
    read = {where.split(" (")[0] for where, _ in texts}
    for folder in (p for p in SHIPPED.iterdir() if p.is_dir()):
        for name in ("config.json", "README.md", "best.safetensors"):
            assert str((folder / name).relative_to(REPO)) in read, f"{folder / name} not read"
    found = [f"{where}: {path}" for where, text in texts for path in absolute_paths(text)]
    assert not found, "absolute paths in shipped files:\n" + "\n".join(found)
