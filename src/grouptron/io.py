"""Writing output files so that a failure never leaves a partial file behind, and reading
back the array caches written that way (which a crash or an old version may have damaged)."""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import os
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TextIO, TypeVar

import numpy as np

from grouptron.errors import GrouptronError

log = logging.getLogger(__name__)
Parsed = TypeVar("Parsed")


def write_csv_atomically(
    path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]
) -> None:
    """Write a CSV into a temporary file beside ``path`` and rename it into place."""

    def write(handle: TextIO) -> None:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)

    _write_atomically(path, write)


def write_array_csv_atomically(
    path: Path, header: Sequence[str], rows: np.ndarray, formats: Sequence[str]
) -> None:
    """Write a numeric (R, C) table as CSV with one printf format per column, atomically."""

    def write(handle: TextIO) -> None:
        handle.write(",".join(header) + "\n")
        np.savetxt(handle, rows, fmt=list(formats), delimiter=",")

    _write_atomically(path, write)


def write_text_atomically(path: Path, text: str) -> None:
    """Write ``text`` into a temporary file beside ``path`` and rename it into place."""
    _write_atomically(path, lambda handle: handle.write(text))


def save_atomically(
    path: Path, save: Callable[[Path], object], *, fsync: bool = False, suffix: str | None = None
) -> None:
    """The one way grouptron writes a file: ``save`` writes it (a table, a picture, an
    animation, a cache, a checkpoint) at a temporary path beside ``path``, which is then
    renamed into place, so a crash or a full disk leaves the previous file, never a torn one.

    Args:
        path: the file to write.
        save: writes the file at the path it is given.
        fsync: flush the file to the disk before the rename (checkpoints).
        suffix: the temporary's suffix; default ``path``'s, so format-by-suffix writers work.
    """
    refuse_folder(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, name = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix if suffix is None else suffix
    )
    os.close(descriptor)
    temporary = Path(name)
    try:
        save(temporary)
        if fsync:
            with temporary.open("rb") as handle:
                os.fsync(handle.fileno())
        os.chmod(temporary, 0o644)  # mkstemp creates 0600; these are ordinary files
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()


def save_npz(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Write arrays as one ``.npz`` (never pickle), atomically: never a half-written file."""
    save_atomically(path, lambda temporary: np.savez(temporary, **arrays))  # type: ignore[arg-type]


def keep_cache_npz(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """:func:`save_npz` for a cache: a read-only or full cache folder costs speed only, so a
    failure is logged, not raised."""
    try:
        save_npz(path, arrays)
    except (OSError, GrouptronError) as error:
        log.warning("could not write the cache file %s (%s)", path, error)


def read_cache_npz(path: Path, parse: Callable[[dict[str, np.ndarray]], Parsed]) -> Parsed | None:
    """``parse`` of the arrays stored at ``path``; None when there is no such file, or when it
    cannot be read or parsed (a damaged or outdated cache: logged, and the caller rebuilds it).
    ``parse`` refuses arrays it cannot use with a ``ValueError`` or ``KeyError``."""
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in stored.files}
        return parse(arrays)
    except (FileNotFoundError, NotADirectoryError):
        return None  # not written yet, or no cache folder at all: nothing to warn about
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as error:
        log.warning("ignoring the unreadable cache file %s (%s); rebuilding it", path, error)
        return None


def read_json_document(path: str | Path, format_name: str) -> dict[str, object]:
    """A JSON file of ours whose ``format`` is ``format_name`` (ValueError otherwise)."""
    document = json.loads(Path(path).read_text())
    if not isinstance(document, dict) or document.get("format") != format_name:
        found = document.get("format") if isinstance(document, dict) else None
        raise ValueError(f"format {found!r}")
    return document


@contextlib.contextmanager
def document_errors(path: str | Path, read_as: str, kind: str, hint: str = "") -> Iterator[None]:
    """Reading a document of ours, its errors as one line: ``cannot read the {read_as}`` for a
    file that cannot be read, ``not a grouptron {kind} (...){hint}`` for one that does not
    parse as one."""
    try:
        yield
    except OSError as error:
        raise GrouptronError(f"{path}: cannot read the {read_as} ({error.strerror})") from None
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise GrouptronError(f"{path}: not a grouptron {kind} ({error}){hint}") from None


def refuse_folder(path: Path, *, inputs: tuple[str | Path, ...] = ()) -> None:
    """Stop early when an output path names a folder (checked again when writing) or one of
    the command's ``inputs`` (writing would replace the file being read)."""
    if path.is_dir():
        raise GrouptronError(f"{path} is a folder; give a file name for the output")
    for source in inputs:
        if path.exists() and Path(source).exists() and path.samefile(source):
            raise GrouptronError(f"{path} is an input of this command; give another output file")


def _write_atomically(path: Path, write: Callable[[TextIO], object]) -> None:
    def save(temporary: Path) -> None:
        with temporary.open("w", newline="") as handle:
            write(handle)

    save_atomically(path, save)
