"""Tables written row block by row block while a live session runs: the recording and the live estimate.

A live session must never lose its recording: :class:`GrowingTable` appends each chunk to
``<name>.partial`` in the destination folder and flushes it to disk at least every
:data:`FLUSH_EVERY_S` seconds, so a crash leaves at most that much unwritten; :meth:`GrowingTable.close`
renames it to its name (a partial file left behind by a killed process is a readable CSV too).
Values are written with 17 significant digits, which read back as the same float64 to the bit.
"""

from __future__ import annotations

import io
import os
import time
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

#: Longest time rows wait in memory before they are flushed to disk, s.
FLUSH_EVERY_S = 1.0
#: Float format: 17 significant digits read back as the same float64.
EXACT = "%.17g"


class GrowingTable:
    """A CSV file written as rows arrive.

    Parameters
    ----------
    path : str or path-like
        The finished file (the folder must exist).
    headers : sequence of str
        Column headers.
    units : sequence of (str or None), optional
        A unit row under the headers (omitted when None or all empty).
    metadata : mapping of str to str, optional
        ``# key: value`` lines before the header (docs/interface.md section 1).
    """

    def __init__(self, path: str | os.PathLike, headers: Sequence[str], *, units: Sequence[str | None] | None = None,
                 metadata: Mapping[str, str] | None = None):
        self.path = Path(path)
        self.partial = self.path.with_name(self.path.name + ".partial")
        self.columns = len(headers)
        self.rows = 0
        self._handle = open(self.partial, "w", encoding="utf-8", newline="\n")
        lines = [f"# {key}: {value}" for key, value in (metadata or {}).items()]
        lines.append(",".join(headers))
        if units is not None and any(units):
            lines.append(",".join(u or "" for u in units))
        self._handle.write("\n".join(lines) + "\n")
        self._flushed = time.monotonic()
        self._pending: list[np.ndarray] = []

    def append(self, rows: np.ndarray) -> None:
        """Append rows (shape (n, columns)): formatted in blocks, and on disk within
        :data:`FLUSH_EVERY_S` (a live loop's chunks are a few rows: one formatting call per second
        instead of one per chunk)."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        if rows.size == 0:
            return
        if rows.shape[1] != self.columns:
            raise ValueError(f"{self.path.name}: {rows.shape[1]} values per row, {self.columns} columns")
        self._pending.append(rows.copy())
        self.rows += len(rows)
        if time.monotonic() - self._flushed >= FLUSH_EVERY_S:
            self.flush()

    def flush(self) -> None:
        """Write what is buffered to disk."""
        if self._pending:
            buffer = io.StringIO()
            np.savetxt(buffer, np.vstack(self._pending), fmt=EXACT, delimiter=",")
            self._handle.write(buffer.getvalue())
            self._pending = []
        self._handle.flush()
        os.fsync(self._handle.fileno())
        self._flushed = time.monotonic()

    def close(self) -> Path:
        """Flush, close and give the file its name; returns it."""
        if not self._handle.closed:
            self.flush()
            self._handle.close()
            os.replace(self.partial, self.path)
        return self.path
