"""Atomic file output, file hashing, and a lock between processes.

Every file limbstiff writes goes through here: the content is written to a temporary file
in the destination directory, flushed to disk, then renamed over the destination with
:func:`os.replace`. A reader therefore sees either the old file or the complete new one,
and a failure (an exception, a full disk) leaves any previous file untouched. A file that
several processes read and rewrite (a folder's ``summary.csv``) is rebuilt under
:func:`locked`, so that no process's update is lost.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

def _read_umask() -> int:
    # Linux exposes the umask without changing it; elsewhere set it and put it back, once.
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _read_umask()


def sha256_file(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    str
        64 lowercase hex digits.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path to write to; on success it replaces ``path`` atomically.

    For writers that insist on a file name (matplotlib, for instance). The parent directory
    is created if needed. If the body raises, the temporary file is removed, ``path`` is left
    as it was and the exception propagates.

    Parameters
    ----------
    path : str or path-like
        Final destination.

    Yields
    ------
    Path
        Temporary file in the same directory as ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        _fsync_file(tmp)
        _set_mode(tmp, path)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    _fsync_dir(path.parent)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write bytes to ``path`` atomically (see :func:`atomic_output`).

    Parameters
    ----------
    path : str or path-like
        Destination; its parent directories are created.
    data : bytes
        The whole content.
    """
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as handle:
            handle.write(data)


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> None:
    """Write text to ``path`` atomically, without newline translation.

    Parameters
    ----------
    path : str or path-like
        As for :func:`atomic_write_bytes`.
    text : str
        The whole content.
    encoding : str
        Text encoding (UTF-8 unless told).
    """
    atomic_write_bytes(path, text.encode(encoding))


@contextlib.contextmanager
def locked(path: str | os.PathLike) -> Iterator[None]:
    """Hold an exclusive lock on the file ``path`` (created if needed, never removed) for the body,
    waiting for any other process that holds it.

    A POSIX record lock (:func:`fcntl.lockf`), which NFS honours between machines (lockd, or
    NFSv4 itself), and which the system releases when its process ends, so that a killed run
    never leaves it held; on Windows a lock on the file's first byte (:func:`msvcrt.locking`).
    Between processes only: two threads of one process both hold it.

    Parameters
    ----------
    path : str or path-like
        The lock file, in the folder whose files it guards.
    """
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            import fcntl
        except ImportError:                          # Windows
            import msvcrt
            while True:
                try:
                    msvcrt.locking(fd, msvcrt.LK_LOCK, 1)    # retries for 10 s, then raises
                    break
                except OSError:
                    continue
        else:
            fcntl.lockf(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)                                 # releases the lock


def _fsync_file(path: Path) -> None:
    with open(path, "rb+") as handle:
        os.fsync(handle.fileno())


def _set_mode(tmp: Path, path: Path) -> None:
    # mkstemp creates the file 0600; give it the mode a plain open() would have,
    # or keep the mode of the file it replaces.
    try:
        mode = path.stat().st_mode & 0o7777
    except OSError:
        mode = 0o666 & ~_UMASK
    with contextlib.suppress(OSError):
        os.chmod(tmp, mode)


def _fsync_dir(directory: Path) -> None:
    # Make the rename itself durable; not possible on every platform, so best effort.
    with contextlib.suppress(OSError, AttributeError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
