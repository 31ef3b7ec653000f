"""User-facing errors: the CLI prints their message on one line and exits with code 2."""

from __future__ import annotations

from pathlib import Path


class GrouptronError(Exception):
    """An error caused by the user's input or environment, with a message meant for people."""


class DataFormatError(GrouptronError):
    """A track file that cannot be read, pointing at the file (and line) at fault."""

    def __init__(self, path: str | Path, message: str, line: int | None = None) -> None:
        where = f"{path}:{line}" if line is not None else f"{path}"
        super().__init__(f"{where}: {message}")
        self.message = message
        self.path = Path(path)
        self.line = line


class DownloadError(GrouptronError):
    """A benchmark file could not be downloaded or did not match its checksum."""


class LateUpdateError(GrouptronError):
    """A live update stamped slightly before the previous one (a message out of order): it is
    dropped, the session unchanged and counted (``StreamSession.faults.late``); go on with the
    next one."""
