"""Where the benchmark files live: ``--data-dir`` > ``$GROUPTRON_DATA`` > the user cache."""

from __future__ import annotations

import os
from pathlib import Path

from grouptron.constants import ALL_LOCATIONS, PARTS, SPLITS
from grouptron.errors import GrouptronError

DATA_ENV = "GROUPTRON_DATA"
CACHE_ENV = "GROUPTRON_CACHE"


def user_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/grouptron`` (``~/.cache/grouptron`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "grouptron"


def resolve_data_dir(explicit: str | Path | None = None) -> Path:
    """The ETH/UCY folder to use: the explicit one, else ``$GROUPTRON_DATA``, else the cache."""
    if explicit:
        return Path(explicit).expanduser()
    from_env = os.environ.get(DATA_ENV, "").strip()
    if from_env:
        return Path(from_env).expanduser()
    return user_cache_dir() / "eth_ucy"


def preprocessed_cache_dir() -> Path:
    """Where preprocessed samples are cached (``$GROUPTRON_CACHE`` or the user cache)."""
    from_env = os.environ.get(CACHE_ENV, "").strip()
    return Path(from_env).expanduser() if from_env else user_cache_dir() / "preprocessed"


def score_cache_dir() -> Path:
    """Where the report keeps per-sample scores (``$GROUPTRON_CACHE/scores`` or the user
    cache's ``scores``)."""
    from_env = os.environ.get(CACHE_ENV, "").strip()
    return (Path(from_env).expanduser() if from_env else user_cache_dir()) / "scores"


def split_files(data_dir: Path, split: str, part: str) -> list[Path]:
    """The sorted ``*.txt`` files of ``<data_dir>/<split>/<part>/``.

    Raises:
        GrouptronError: for an unknown split or part, or when the folder has no files, with a
            hint on how to get the data.
    """
    if split == ALL_LOCATIONS:
        return _all_locations_files(data_dir, part)
    if split not in SPLITS:
        raise GrouptronError(f"unknown split {split!r}; choose from {', '.join(SPLITS)}")
    if part not in PARTS:
        raise GrouptronError(f"unknown part {part!r}; choose from {', '.join(PARTS)}")
    folder = data_dir / split / part
    files = sorted(folder.glob("*.txt"))
    if not files:
        raise GrouptronError(
            f"no ETH/UCY files in {folder}; run `grouptron data fetch` "
            f"(or point --data-dir / ${DATA_ENV} at a copy of the benchmark)"
        )
    return files


def _all_locations_files(data_dir: Path, part: str) -> list[Path]:
    """The train and val parts of every location (each file once: a location's parts sit in
    the folders of all four other splits); there is no held-out part."""
    if part != "train":
        raise GrouptronError(
            f"{ALL_LOCATIONS} has no {part} part: it trains on the train and val parts of "
            "every location"
        )
    by_name: dict[str, Path] = {}
    for split in SPLITS:
        for name in ("train", "val"):
            for path in split_files(data_dir, split, name):
                by_name.setdefault(path.name, path)
    return [by_name[name] for name in sorted(by_name)]
