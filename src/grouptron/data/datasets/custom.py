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

The train part may name its sources, so that a big one does not drown the rest: every source
gets its share of each epoch's draws (equal shares unless ``[shares]`` gives them):

    [parts.train]
    eth_ucy = ["all_data/biwi_eth.txt", ...]
    station = ["gc/gc_000.txt", ...]
    [shares]
    eth_ucy = 0.5
    station = 0.5
"""

from __future__ import annotations

import json
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grouptron.config import DataConfig
from grouptron.constants import SPLITS
from grouptron.data.datasets.dataset import PartData, load_files_part
from grouptron.data.formats.layout import RecordingFormat, parse_columns
from grouptron.data.formats.spelling import FILE_KEYS
from grouptron.data.prepare.samples import SampleSet
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
        sources: the train part's named sources, in the order their files appear in
            ``parts["train"]``; empty where the train part is one list of files.
        shares: each source's share of an epoch's draws (summing to 1); empty where the train
            part names no sources, so that an epoch is one pass over every sample.
    """

    name: str
    source: Path
    parts: dict[str, tuple[Path, ...]]
    recording: RecordingFormat
    sources: dict[str, tuple[Path, ...]] = field(default_factory=dict)
    shares: dict[str, float] = field(default_factory=dict)

    def files(self, part: str) -> list[Path]:
        """The files of ``part`` (``train``, ``val`` or ``test``); an error where it is absent."""
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
    unknown = sorted(set(values) - {"name", "format", "parts", "shares"})
    if unknown:
        raise GrouptronError(
            f"{path}: unknown keys {', '.join(unknown)} (name, format, parts, shares)"
        )
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
    parts, sources = _parts(path, values.get("parts"))
    shares = _shares(path, sources, values.get("shares"))
    return DatasetDescription(name.strip(), path.resolve(), parts, recording, sources, shares)


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


def _parts(
    path: Path, parts: Any
) -> tuple[dict[str, tuple[Path, ...]], dict[str, tuple[Path, ...]]]:
    """The files of each part, and the train part's files by named source."""
    if not isinstance(parts, dict) or not parts:
        raise GrouptronError(f"{path}: 'parts' must list the files of train, val and/or test")
    out, sources = {}, {}
    for part, files in parts.items():
        if part not in PARTS:
            raise GrouptronError(f"{path}: unknown part {part!r}; parts are {', '.join(PARTS)}")
        if part == "train" and isinstance(files, dict):
            if not files:
                raise GrouptronError(f"{path}: the train part names no sources")
            sources = {str(k): _files(path, f"train source {k!r}", v) for k, v in files.items()}
            out[part] = tuple(f for named in sources.values() for f in named)
        else:
            out[part] = _files(path, part, files)
    return out, sources


def _files(path: Path, what: str, files: Any) -> tuple[Path, ...]:
    if isinstance(files, str):
        files = [files]
    if not isinstance(files, list):
        raise GrouptronError(f"{path}: the {what} part is a file or a list of files")
    resolved = tuple((path.parent / expand_variables(path, f)).resolve() for f in files)
    if not resolved:
        raise GrouptronError(f"{path}: the {what} part lists no files")
    missing = [str(f) for f in resolved if not f.is_file()]
    if missing:
        named = sorted(set(_VARIABLE.findall(" ".join(map(str, files)))))
        hint = f" (set ${named[0][0]} to the folder that holds them)" if named else ""
        raise GrouptronError(f"{path}: {what} files not found: {', '.join(missing)}{hint}")
    return resolved


def _shares(path: Path, sources: dict[str, tuple[Path, ...]], shares: Any) -> dict[str, float]:
    """Each named train source's share of an epoch (normalised to sum to 1); equal shares
    where ``[shares]`` is absent, none where the train part names no sources."""
    if shares is None:
        return {name: 1.0 / len(sources) for name in sources}
    if not isinstance(shares, dict) or not sources:
        raise GrouptronError(f"{path}: [shares] gives each named source of [parts.train] a share")
    if set(shares) != set(sources):
        raise GrouptronError(
            f"{path}: [shares] must name exactly the train sources ({', '.join(sources)}), "
            f"not {', '.join(map(str, shares))}"
        )
    values = {k: shares[k] for k in sources}
    bad = [k for k, v in values.items() if isinstance(v, bool) or not isinstance(v, (int, float))]
    if bad or not all(v >= 0 for v in values.values()) or not sum(values.values()) > 0:
        raise GrouptronError(f"{path}: shares are numbers >= 0, not all 0")
    total = float(sum(values.values()))
    return {k: float(v) / total for k, v in values.items()}


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


def train_sample_weights(dataset: DatasetDescription, samples: SampleSet) -> np.ndarray | None:
    """(S,) the probability of drawing each training sample so that every named source gets
    its share of an epoch (uniform within a source); None where the train part names no
    sources. ``samples`` are the train part's, whose scene ``i`` is its file ``i``."""
    if not dataset.shares:
        return None
    sizes = [len(files) for files in dataset.sources.values()]
    source_of_file = np.repeat(np.arange(len(sizes)), sizes)  # (num_files,)
    source = source_of_file[samples.scene_index]  # (S,)
    counts = np.bincount(source, minlength=len(sizes))
    share = np.asarray(list(dataset.shares.values()))
    empty = [n for n, c, s in zip(dataset.shares, counts, share, strict=True) if c == 0 and s > 0]
    if empty:
        raise GrouptronError(f"{dataset.source}: train source {empty[0]!r} gives no samples")
    return share[source] / counts[source]
