"""Atomic writes: the old file or the whole new one, never a part; errors name the file."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from track_envs.infra.atomic import FileWriteError, atomic_path, atomic_write, check_writable, write_text


def test_writes_whole_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "tracks.txt"
    with atomic_write(target) as f:
        f.write("1,1,0,0\n")
        assert not target.exists()  # nothing visible until the block ends
    assert target.read_text() == "1,1,0,0\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tracks.txt"]


def test_exception_in_block_keeps_old_file(tmp_path: Path) -> None:
    target = write_text(tmp_path / "a.csv", "old\n")
    with pytest.raises(RuntimeError, match="boom"), atomic_write(target) as f:
        f.write("new, half")
        raise RuntimeError("boom")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["a.csv"]


def test_keeps_permissions_of_the_old_file(tmp_path: Path) -> None:
    target = write_text(tmp_path / "a.json", "{}")
    os.chmod(target, 0o640)
    write_text(target, "[]")
    assert target.stat().st_mode & 0o777 == 0o640


def test_new_file_gets_umask_default_not_0600(tmp_path: Path) -> None:
    umask = os.umask(0o022)
    try:
        target = write_text(tmp_path / "new.txt", "x")
    finally:
        os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o644


def test_atomic_path_for_libraries_keeps_suffix(tmp_path: Path) -> None:
    with atomic_path(tmp_path / "rec.json") as tmp:
        assert tmp.name.startswith(".rec.json.") and tmp.suffix == ".part"  # not *.json
    with atomic_path(tmp_path / "fig.png", keep_suffix=True) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path
        tmp.write_bytes(b"png")
    assert (tmp_path / "fig.png").read_bytes() == b"png"


@pytest.mark.parametrize("where", ["/proc/track.txt", "missing-dir/x.txt"])
def test_check_writable_names_file_and_cause(tmp_path: Path, where: str) -> None:
    path = where if where.startswith("/") else tmp_path / where
    with pytest.raises(FileWriteError, match=str(path).replace("/", ".")):
        check_writable(path)


def test_check_writable_rejects_directory(tmp_path: Path) -> None:
    with pytest.raises(FileWriteError, match="is a directory"):
        check_writable(tmp_path)


def test_failed_write_under_file_size_limit_leaves_old_file(tmp_path: Path) -> None:
    """A disk-full-like failure (RLIMIT_FSIZE) mid-write: the old file survives, the error names it."""
    target = write_text(tmp_path / "out.txt", "old\n")
    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))\n"
        "from track_envs.infra.atomic import atomic_write, FileWriteError\n"
        "try:\n"
        "    with atomic_write(sys.argv[1]) as f:\n"
        "        for _ in range(10000):\n"
        "            f.write('1,2,3.25,4.5\\n')\n"
        "except FileWriteError as e:\n"
        "    print(e)\n"
        "    sys.exit(3)\n"
    )
    assert resource.RLIMIT_FSIZE  # POSIX
    done = subprocess.run(
        [sys.executable, "-c", code, str(target)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 3, done.stderr
    assert str(target) in done.stdout and "EFBIG" in done.stdout
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]
