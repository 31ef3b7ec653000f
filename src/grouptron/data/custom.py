"""Datasets of one's own: a small description file naming the recordings of each part.

    # corridor.toml
    name = "corridor"
    [format]                      # how the files are laid out (RecordingFormat)
    columns = "id,frame,x,y,z"
    fps = 16
    units = "cm"
    [parts]                       # paths relative to this file
    train = ["uo-145.txt", "uo-180.txt"]
    val = ["uo-300-a.txt"]
    test = ["uo-300-b.txt"]

JSON with the same keys works too. A custom dataset never gets the ETH/UCY per-split presets.
"""

from __future__ import annotations

import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grouptron.config import DataConfig
from grouptron.constants import SPLITS
from grouptron.data.dataset import PartData, load_files_part
from grouptron.data.recording import RecordingFormat, parse_columns
from grouptron.data.spelling import FILE_KEYS
from grouptron.errors import GrouptronError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

PARTS = ("train", "val", "test")
FORMAT_KEYS = ("columns", "fps", "units", "max_gap_s", "check_speed")


@dataclass(frozen=True)
class DatasetDescription:
    """A dataset of one's own.

    Attributes:
        name: what runs and reports call it (never an ETH/UCY split name).
        source: the description file (stored in the configuration of runs trained on it).
        parts: the files of each part present (``train``, ``val``, ``test``).
        recording: how the files are laid out.
    """

    name: str
    source: Path
    parts: dict[str, tuple[Path, ...]]
    recording: RecordingFormat

    def files(self, part: str) -> list[Path]:
        if part not in self.parts:
            raise GrouptronError(f"{self.source}: the dataset has no {part!r} part")
        return list(self.parts[part])


def _load(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text()
        values = json.loads(text) if path.suffix == ".json" else tomllib.loads(text)
    except (OSError, ValueError) as exc:
        raise GrouptronError(f"{path}: cannot read the dataset description ({exc})") from None
    if not isinstance(values, dict):
        raise GrouptronError(f"{path}: a dataset description is a table of keys")
    return values


def read_dataset(path: str | Path) -> DatasetDescription:
    """Read and check a dataset description (TOML, or JSON for a ``.json`` file)."""
    path = Path(path)
    values = _load(path)
    unknown = sorted(set(values) - {"name", "format", "parts"})
    if unknown:
        raise GrouptronError(f"{path}: unknown keys {', '.join(unknown)} (name, format, parts)")
    name = values.get("name")
    if not isinstance(name, str) or not name.strip():
        raise GrouptronError(f"{path}: 'name' must be a non-empty string")
    if name in SPLITS:
        raise GrouptronError(
            f"{path}: the name {name!r} is an ETH/UCY split; a dataset of your own needs another"
        )
    fmt = values.get("format", {})
    bad = sorted(set(fmt) - set(FORMAT_KEYS)) if isinstance(fmt, dict) else ["format"]
    if bad:
        raise GrouptronError(f"{path}: unknown format keys {', '.join(bad)} ({FORMAT_KEYS})")
    try:
        if isinstance(fmt.get("columns"), str):
            fmt = {**fmt, "columns": parse_columns(fmt["columns"], FILE_KEYS)}
        recording = RecordingFormat(**fmt, spelling=FILE_KEYS)
    except TypeError as exc:
        raise GrouptronError(f"{path}: bad format ({exc})") from None
    except GrouptronError as exc:
        raise GrouptronError(f"{path}: format: {exc}") from None
    parts = _parts(path, values.get("parts"))
    return DatasetDescription(name.strip(), path.resolve(), parts, recording)


_VARIABLE = re.compile(r"\$\{(\w+)(?::-([^}]*))?\}")


def expand_variables(path: Path, entry: Any) -> str:
    """A file entry with ``${NAME}`` or ``${NAME:-default}`` replaced by the environment
    variable (or the default where it is unset), so that a description can name a data
    folder that lives elsewhere on each machine; an unset variable without a default is one
    line that names it."""
    if not isinstance(entry, str):
        raise GrouptronError(f"{path}: a file entry must be a string, not {entry!r:.40}")

    def value(match: re.Match[str]) -> str:
        name, default = match.group(1), match.group(2)
        found = os.environ.get(name) or default
        if found is None:
            raise GrouptronError(f"{path}: {entry!r} names ${name}, which is not set")
        return found

    return _VARIABLE.sub(value, entry)


def _parts(path: Path, parts: Any) -> dict[str, tuple[Path, ...]]:
    if not isinstance(parts, dict) or not parts:
        raise GrouptronError(f"{path}: 'parts' must list the files of train, val and/or test")
    out = {}
    for part, files in parts.items():
        if part not in PARTS:
            raise GrouptronError(f"{path}: unknown part {part!r}; parts are {', '.join(PARTS)}")
        if isinstance(files, str):
            files = [files]
        resolved = tuple((path.parent / expand_variables(path, f)).resolve() for f in files)
        if not resolved:
            raise GrouptronError(f"{path}: the {part} part lists no files")
        missing = [str(f) for f in resolved if not f.is_file()]
        if missing:
            named = sorted(set(_VARIABLE.findall(" ".join(map(str, files)))))
            hint = f" (set ${named[0][0]} to the folder that holds them)" if named else ""
            raise GrouptronError(f"{path}: {part} files not found: {', '.join(missing)}{hint}")
        out[part] = resolved
    return out


def load_dataset_part(
    dataset: DatasetDescription, part: str, config: DataConfig, *, use_cache: bool = True
) -> PartData:
    """The samples of one part (cached like the benchmark's, keyed by content and layout)."""
    return load_files_part(
        dataset.files(part),
        dataset.name,
        part,
        config,
        recording=dataset.recording,
        use_cache=use_cache,
    )
