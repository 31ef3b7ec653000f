"""The downloader against an HTTP server on 127.0.0.1: good files, corrupt files, missing files."""

from __future__ import annotations

import functools
import hashlib
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from grouptron.cli import main
from grouptron.data.datasets.download import (
    fetch_dataset,
    file_sha256,
    parse_checksums,
    shipped_checksums,
)
from grouptron.errors import DownloadError, GrouptronError


class _QuietHandler(SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


@contextmanager
def serve(folder: Path) -> Iterator[str]:
    """Serve ``folder`` on a free loopback port; yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(folder))
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def make_source(folder: Path) -> dict[str, str]:
    files = {"eth/test/a.txt": b"0\t1\t0.0\t0.0\n", "univ/train/b.txt": b"10\t2\t1.0\t2.0\n" * 500}
    for relative, content in files.items():
        (folder / relative).parent.mkdir(parents=True, exist_ok=True)
        (folder / relative).write_bytes(content)
    return {r: hashlib.sha256(c).hexdigest() for r, c in files.items()}


def leftovers(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.startswith(".part-")]


def test_fetch_downloads_verifies_and_repairs(tmp_path: Path) -> None:
    source, target = tmp_path / "source", tmp_path / "target"
    sums = make_source(source)
    with serve(source) as url:
        first = fetch_dataset(target, base_url=url, checksums=sums)
        assert sorted(first.downloaded) == sorted(sums)
        assert all(file_sha256(target / r) == s for r, s in sums.items())
        second = fetch_dataset(target, base_url=url, checksums=sums)
        assert sorted(second.verified) == sorted(sums) and not second.downloaded
        (target / "eth/test/a.txt").write_text("tampered\n")
        third = fetch_dataset(target, base_url=url, checksums=sums)
        assert third.replaced == ["eth/test/a.txt"]
    assert file_sha256(target / "eth/test/a.txt") == sums["eth/test/a.txt"]
    assert not leftovers(target)


def test_corrupt_download_leaves_no_file(tmp_path: Path) -> None:
    source, target = tmp_path / "source", tmp_path / "target"
    sums = make_source(source)
    (source / "univ/train/b.txt").write_bytes(b"corrupted bytes\n")
    with serve(source) as url, pytest.raises(DownloadError, match="checksum mismatch"):
        fetch_dataset(target, base_url=url, checksums=sums)
    assert not (target / "univ/train/b.txt").exists()
    assert not leftovers(target)


def test_missing_file_on_server(tmp_path: Path) -> None:
    source, target = tmp_path / "source", tmp_path / "target"
    sums = make_source(source)
    (source / "eth/test/a.txt").unlink()
    with serve(source) as url, pytest.raises(DownloadError, match="404"):
        fetch_dataset(target, base_url=url, checksums=sums)
    assert not leftovers(target)


def test_cli_reports_a_corrupt_download_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = tmp_path / "source"
    source.mkdir()
    with serve(source) as url:  # serves nothing the shipped list names
        code = main(["data", "fetch", "--data-dir", str(tmp_path / "t"), "--base-url", url])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err[-1].startswith("grouptron: error: ") and "download failed" in err[-1]


def test_checksum_list_refuses_unsafe_paths() -> None:
    with pytest.raises(GrouptronError, match="unsafe path"):
        parse_checksums("a" * 64 + "  ../../etc/passwd\n")


@pytest.mark.realdata
def test_fetch_the_real_benchmark_from_a_loopback_mirror(eth_ucy_dir: Path, tmp_path: Path) -> None:
    sums = shipped_checksums()
    assert len(sums) == 82
    with serve(eth_ucy_dir) as url:
        report = fetch_dataset(tmp_path / "eth_ucy", base_url=url)
    assert len(report.downloaded) == len(sums)
    assert (tmp_path / "eth_ucy/univ/test/students001.txt").is_file()
