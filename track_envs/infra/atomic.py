"""Atomic file writes: a file is either written whole or not at all.

Every file the project writes (tracks, detections, crossings, calibration sidecars, pose results,
bench records and tables, figures, model weights, recordings) goes through
[`atomic_write`][track_envs.io.atomic_write]:
the content is written to a temporary file in the target's directory (same file system), flushed
and ``fsync``-ed, then ``os.replace``-d onto the target name — an atomic rename on POSIX and
Windows. A write that fails part way (disk full, a file-size limit, an exception in the code that
makes the content, Ctrl-C) removes the temporary file and leaves the old target untouched (or no
target at all); the error is a [`FileWriteError`][track_envs.io.FileWriteError] naming the target and the
cause.

The target's directory must exist (as for ``open``); a missing directory, a read-only place or a
path under ``/proc`` is reported before anything is computed by
[`check_writable`][track_envs.io.check_writable], which the command-line tools call on their ``--out``
arguments first.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any, Literal, overload

__all__ = [
    "FileWriteError",
    "atomic_path",
    "atomic_write",
    "check_writable",
    "save_figure",
    "write_bytes",
    "write_text",
    "write_with",
]


class FileWriteError(OSError):
    """A file could not be written; the message names the file and the cause.

    Subclasses ``OSError`` (with the cause's ``errno``), so ``except OSError`` still catches it.
    """


def _describe(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.errno is not None:
        name = errno.errorcode.get(exc.errno, str(exc.errno))
        text = exc.strerror or os.strerror(exc.errno)
        return f"{text} ({name})"
    return f"{type(exc).__name__}: {exc}"


def _error(path: str | os.PathLike[str], exc: BaseException, doing: str = "cannot write") -> FileWriteError:
    err = FileWriteError(f"{os.fspath(path)}: {doing}: {_describe(exc)}")
    if isinstance(exc, OSError):
        err.errno = exc.errno
    return err


def check_writable(path: str | os.PathLike[str]) -> Path:
    """Fail early, before any work, if ``path`` cannot be written.

    Checks that the directory exists, is a directory and lets us create a file (by creating and
    removing a temporary file there, the same way [`atomic_write`][track_envs.io.atomic_write] will), and that
    ``path`` is not an existing directory. Returns ``path`` as a `Path`.

    Raises:
        FileWriteError: naming ``path`` and the cause.
    """
    target = Path(path)
    if target.is_dir():
        raise FileWriteError(errno.EISDIR, f"{target}: cannot write: it is a directory")
    directory = target.parent
    if not directory.exists():
        raise FileWriteError(errno.ENOENT, f"{target}: cannot write: directory {directory} does not exist")
    if not directory.is_dir():
        raise FileWriteError(errno.ENOTDIR, f"{target}: cannot write: {directory} is not a directory")
    try:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{target.name}.", suffix=".part")
    except OSError as exc:
        raise _error(target, exc) from exc
    os.close(fd)
    os.unlink(tmp)
    return target


@overload
def atomic_write(
    path: str | os.PathLike[str], mode: Literal["w"] = ..., *, encoding: str = ..., newline: str | None = ...
) -> contextlib.AbstractContextManager[IO[str]]: ...
@overload
def atomic_write(
    path: str | os.PathLike[str], mode: Literal["wb"], *, encoding: str = ..., newline: str | None = ...
) -> contextlib.AbstractContextManager[IO[bytes]]: ...
def atomic_write(
    path: str | os.PathLike[str], mode: str = "w", *, encoding: str = "utf-8", newline: str | None = None
) -> contextlib.AbstractContextManager[IO[Any]]:
    """A context manager yielding a handle whose content replaces ``path`` when the block ends.

    ``mode`` is ``"w"`` (text, ``encoding`` and ``newline`` as for ``open``) or ``"wb"``. If the
    block raises, the target is left as it was and the temporary file is removed; an ``OSError``
    (raised in the block or while writing, flushing or renaming) becomes a
    [`FileWriteError`][track_envs.io.FileWriteError] naming ``path``. Other exceptions propagate unchanged.

    Example::

        with atomic_write("tracks.txt") as f:
            for chunk in chunks:
                f.write(chunk)
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write mode {mode!r}: use 'w' or 'wb'")
    return _atomic(Path(path), mode, encoding, newline)


@contextlib.contextmanager
def _atomic(target: Path, mode: str, encoding: str, newline: str | None) -> Iterator[IO[Any]]:
    with atomic_path(target) as tmp:
        try:
            if mode == "wb":
                handle: IO[Any] = open(tmp, "wb")  # noqa: SIM115 (closed below)
            else:
                handle = open(tmp, "w", encoding=encoding, newline=newline)  # noqa: SIM115
        except OSError as exc:
            raise _error(target, exc) from exc
        with handle:
            yield handle
            try:
                handle.flush()
                os.fsync(handle.fileno())
            except OSError as exc:
                raise _error(target, exc) from exc


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, keep_suffix: bool = False) -> Iterator[Path]:
    """A temporary path beside ``path`` for writers that want a file name (``np.save``,
    ``safetensors``, ``matplotlib``): whatever the block writes there is renamed onto ``path`` when
    it ends without error; otherwise removed. The temporary name is hidden and ends in ``.part``
    (so a directory scan for ``*.json`` never sees a write in progress); ``keep_suffix=True`` adds
    the target's suffix after it, for libraries that pick a format from the name (``savefig``,
    Pillow) or add one when it is missing (stable-baselines3's ``.zip``).

    Raises:
        FileWriteError: naming ``path``, when the temporary file cannot be made or written, or the
            rename fails.
    """
    target = Path(path)
    try:
        fd, name = tempfile.mkstemp(
            dir=target.parent,
            prefix=f".{target.name}.",
            suffix=".part" + (target.suffix if keep_suffix else ""),
        )
    except OSError as exc:
        raise _error(target, exc) from exc
    os.close(fd)
    tmp = Path(name)
    try:
        try:
            yield tmp
        except OSError as exc:
            if isinstance(exc, FileWriteError):
                raise
            raise _error(target, exc) from exc
        try:
            _keep_mode(tmp, target)
            os.replace(tmp, target)
        except OSError as exc:
            raise _error(target, exc) from exc
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _keep_mode(tmp: Path, target: Path) -> None:
    """Give the new file the old file's permissions, or the umask's default (mkstemp makes 0600)."""
    try:
        mode = target.stat().st_mode & 0o777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    os.chmod(tmp, mode)


def write_text(path: str | os.PathLike[str], text: str, *, encoding: str = "utf-8") -> Path:
    """``Path.write_text``, atomically; returns the path."""
    with atomic_write(path, "w", encoding=encoding) as f:
        f.write(text)
    return Path(path)


def write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """``Path.write_bytes``, atomically; returns the path."""
    with atomic_write(path, "wb") as f:
        f.write(data)
    return Path(path)


def write_with(path: str | os.PathLike[str], writer: Callable[[Path], object]) -> Path:
    """Call ``writer(tmp)`` to write a file at a temporary path (with ``path``'s suffix, for
    writers that pick a format from it), then rename it onto ``path``."""
    with atomic_path(path, keep_suffix=True) as tmp:
        writer(tmp)
    return Path(path)


def save_figure(fig: Any, path: str | os.PathLike[str], **savefig_kwargs: Any) -> Path:
    """``fig.savefig(path, **savefig_kwargs)`` for a matplotlib figure, atomically (the format
    follows ``path``'s suffix, as savefig's does); returns the path."""
    with atomic_path(path, keep_suffix=True) as tmp:
        fig.savefig(tmp, **savefig_kwargs)
    return Path(path)
