"""A probe file: a random token written to a folder, to check that another machine (a cluster's
worker) reads the folder as this one does."""

from __future__ import annotations

import contextlib
import uuid
from pathlib import Path
from typing import Iterator


@contextlib.contextmanager
def probe_file(folder: str | Path) -> Iterator[tuple[Path, str]]:
    """A hidden file in ``folder`` holding a random token, removed on leaving the block.

    Yields
    ------
    path : Path
        The probe, an absolute path.
    token : str
        What it holds.
    """
    token = uuid.uuid4().hex
    path = Path(folder).resolve() / f".limbstiff-probe-{token}"
    path.write_text(token, encoding="utf-8")
    try:
        yield path, token
    finally:
        path.unlink(missing_ok=True)


def holds(path: str | Path, token: str) -> bool:
    """Whether the file at ``path`` can be read and holds ``token``."""
    try:
        return Path(path).read_text(encoding="utf-8") == token
    except OSError:
        return False
