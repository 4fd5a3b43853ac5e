"""Tables written row block by row block while a live session runs: the recording and the live estimate.

:class:`SegmentedRecording` is a live session's recording, one file per stretch without a break.

A live session must never lose its recording: :class:`GrowingTable` appends each chunk to
``<name>.partial`` in the destination folder and flushes it to disk at least every
:data:`FLUSH_EVERY_S` seconds, so a crash leaves at most that much unwritten; :meth:`GrowingTable.close`
renames it to its name (a partial file left behind by a killed process is a readable CSV too).
Values are written as the shortest text that reads back as the same float64 (Python's ``repr``), by
the one CSV writer (:mod:`.csv_writer`). The recording's headers carry their units
(:func:`unit_headers`: ``angle`` of unit ``deg`` is ``angle_deg``), so that it is a standard trial
file without a unit row, read as it was received.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..units import UNITS, parse_standard_header, same_unit, split_header
from .csv_writer import csv_head, csv_rows

#: Longest time rows wait in memory before they are flushed to disk, s.
FLUSH_EVERY_S = 1.0


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
        self._handle = open(self.partial, "wb")
        self._handle.write(csv_head(headers, metadata=metadata, units=units))
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
            rows = np.vstack(self._pending)
            self._handle.write(csv_rows(list(rows.T), digits=None, na_rep="nan"))
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


def unit_headers(headers: Sequence[str], units: Sequence[str | None]) -> tuple[list[str], list[str] | None]:
    """Headers that carry their units, and the unit row still needed (None: none is).

    A header without a unit gets ``_<unit>`` (``angle`` and ``deg`` → ``angle_deg``; ``channel_2``
    and ``deg`` → ``channel_2_deg``, which a protocol still finds as ``channel_2``); one that names
    its unit already, or has none to carry, stays. A unit that cannot be read back from its header
    (not in the unit table, on a header that is no standard quantity), one that differs from the
    unit in its header, or headers made equal by their units keep the headers as given and the
    unit row, which the reader reads as before.

    Parameters
    ----------
    headers : sequence of str, length c
    units : sequence of (str or None), length c

    Returns
    -------
    headers : list of str, length c
    units : list of str, length c, or None
    """
    out = []
    for header, unit in zip(headers, units):
        unit = (unit or "").strip()
        written = _unit_written(header)
        if not unit or (written is not None and same_unit(written, unit)):
            out.append(header)
        elif written is None and _unit_written(f"{header}_{unit}") == unit:
            out.append(f"{header}_{unit}")
        else:
            return list(headers), [u or "" for u in units]
    if len(set(out)) < len(out):
        return list(headers), [u or "" for u in units]
    return out, None


def _unit_written(header: str) -> str | None:
    """The unit a header names: a known one at its end, or any after a standard quantity."""
    known = split_header(header)[1]
    standard = parse_standard_header(header)
    return known if known in UNITS else standard[1] if standard else None


class SegmentedRecording:
    """A live session's samples as received: ``<trial>.csv``, and after each break
    ``<trial>-2.csv``, ``<trial>-3.csv``… (a suffix whose file and output folder are both free, so
    that no other trial's file is replaced).

    ``time_s`` is each sample's place on the stream's nominal grid: the previous one's plus the
    whole number of periods between their time stamps, at least one. It always increases, keeps the
    gaps, and does not drift with a sender's clock or jitter with LSL's clock correction (the raw
    time stamps are the live table's).

    Parameters
    ----------
    out : Path
        Folder of the recording files.
    trial : str
    headers, units : sequence of str
        The channels' headers and units (written in the headers where they can be: :func:`unit_headers`).
    metadata : mapping of str to str
    fs : float, Hz
        The stream's nominal rate.
    """

    def __init__(self, out: Path, trial: str, headers, units, metadata, fs: float):
        self.out, self.trial, self.metadata = Path(out), trial, metadata
        self.headers, self.units = unit_headers(["time_s", *headers], ["s", *units])
        self.fs = float(fs)
        self.tables: list[GrowingTable] = []
        self.zero = 0.0
        self._last_stamp = self._last_index = 0

    def segment(self, t0: float) -> None:
        """Start the next file at the sample stamped ``t0`` (LSL time, s)."""
        if self.tables:
            self.tables[-1].close()
        name, k = self.trial, len(self.tables) + 1
        if self.tables:
            name = f"{self.trial}-{k}"
            while (self.out / f"{name}.csv").exists() or (self.out / name).exists():
                k += 1
                name = f"{self.trial}-{k}"
        meta = {**self.metadata, "lsl_time_at_zero_s": repr(float(t0))}
        self.tables.append(GrowingTable(self.out / f"{name}.csv", self.headers, units=self.units, metadata=meta))
        if len(self.tables) == 1:
            self.zero = float(t0)
        self._last_stamp, self._last_index = float(t0), -1

    def append(self, timestamps: np.ndarray, values: np.ndarray) -> None:
        """Append samples (stamps (n,), s; values (n, channels)) to the current file."""
        if not len(timestamps):
            return
        steps = np.diff(np.concatenate([[self._last_stamp], timestamps])) * self.fs
        index = self._last_index + np.cumsum(np.maximum(1, np.round(steps)))
        self._last_stamp, self._last_index = float(timestamps[-1]), int(index[-1])
        self.tables[-1].append(np.column_stack([index / self.fs, values]))

    def flush(self) -> None:
        """Put what is buffered on disk (a stalled stream's last rows)."""
        if self.tables:
            self.tables[-1].flush()

    def close(self) -> list[Path]:
        """Close every file; their paths."""
        return [table.close() for table in self.tables]
