"""Download the ETH/UCY benchmark files from their public source and verify every checksum.

Files are streamed into a temporary file next to their destination, hashed while written, and
renamed into place only when the SHA256 matches: an interrupted or corrupted download never
leaves a file that looks complete.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path, PurePosixPath

from tqdm import tqdm

from grouptron.errors import DownloadError, GrouptronError

SOURCE_COMMIT = "1031c7bd1a444273af378c1ec1dcca907ba59830"
DEFAULT_BASE_URL = (
    "https://raw.githubusercontent.com/StanfordASL/Trajectron-plus-plus/"
    f"{SOURCE_COMMIT}/experiments/pedestrians/raw"
)
"""Where the benchmark copy comes from (same relative paths as the checksum list)."""
BASE_URL_ENV = "GROUPTRON_DATA_URL"
CHUNK_BYTES = 1 << 16


@dataclass
class FetchReport:
    """What :func:`fetch_dataset` did: files already valid, downloaded, and replaced."""

    verified: list[str] = field(default_factory=list)
    downloaded: list[str] = field(default_factory=list)
    replaced: list[str] = field(default_factory=list)


def parse_checksums(text: str) -> dict[str, str]:
    """``sha256  ./relative/path`` lines -> {relative path: sha256}, refusing unsafe paths."""
    sums: dict[str, str] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        parts = line.split()
        if len(parts) != 2 or len(parts[0]) != 64:
            raise GrouptronError(f"checksum list line {number}: expected 'sha256  path'")
        relative = PurePosixPath(parts[1].removeprefix("./"))
        if relative.is_absolute() or ".." in relative.parts:
            raise GrouptronError(f"checksum list line {number}: unsafe path {parts[1]!r}")
        sums[str(relative)] = parts[0].lower()
    return sums


def shipped_checksums() -> dict[str, str]:
    """The checksum list shipped inside the package."""
    text = resources.files("grouptron.data.datasets").joinpath("SHA256SUMS").read_text()
    return parse_checksums(text)


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's contents in hex digits (read in chunks)."""
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(CHUNK_BYTES), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _download_one(url: str, target: Path, expected_sha256: str, timeout_s: float) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    descriptor, part_name = tempfile.mkstemp(dir=target.parent, prefix=".part-")
    try:
        digest = hashlib.sha256()
        with (
            os.fdopen(descriptor, "wb") as handle,
            urllib.request.urlopen(url, timeout=timeout_s) as response,
        ):
            total = int(response.headers.get("Content-Length") or 0) or None
            with tqdm(total=total, unit="B", unit_scale=True, desc=target.name, leave=False) as bar:
                for chunk in iter(lambda: response.read(CHUNK_BYTES), b""):
                    handle.write(chunk)
                    digest.update(chunk)
                    bar.update(len(chunk))
        if digest.hexdigest() != expected_sha256:
            raise DownloadError(
                f"{url}: checksum mismatch (expected {expected_sha256[:12]}..., "
                f"got {digest.hexdigest()[:12]}...); the file was not saved"
            )
        os.chmod(part_name, 0o644)  # mkstemp creates 0600; the data are ordinary files
        os.replace(part_name, target)
    except (urllib.error.URLError, OSError, TimeoutError) as exc:
        raise DownloadError(f"{url}: download failed: {exc}") from None
    finally:
        if os.path.exists(part_name):
            os.unlink(part_name)


def fetch_dataset(
    data_dir: Path,
    base_url: str | None = None,
    checksums: dict[str, str] | None = None,
    timeout_s: float = 60.0,
) -> FetchReport:
    """Make ``data_dir`` hold every benchmark file with the right checksum.

    Files that already verify are left alone; missing or corrupt ones are downloaded from
    ``base_url`` (default: the Trajectron++ repository at a fixed commit, or
    ``$GROUPTRON_DATA_URL``).

    Raises:
        DownloadError: when a file cannot be fetched or does not match its checksum; files
            fetched before the failure are kept (they verified), nothing partial is left.
    """
    sums = checksums if checksums is not None else shipped_checksums()
    base = (base_url or os.environ.get(BASE_URL_ENV) or DEFAULT_BASE_URL).rstrip("/")
    report = FetchReport()
    pending: list[tuple[str, str, bool]] = []
    for relative, sha in sums.items():
        target = data_dir / relative
        if target.is_file():
            if file_sha256(target) == sha:
                report.verified.append(relative)
                continue
            pending.append((relative, sha, True))
        else:
            pending.append((relative, sha, False))
    progress = tqdm(pending, desc="downloading ETH/UCY", unit="file", disable=not pending)
    for relative, sha, existed in progress:
        _download_one(f"{base}/{relative}", data_dir / relative, sha, timeout_s)
        (report.replaced if existed else report.downloaded).append(relative)
    return report
