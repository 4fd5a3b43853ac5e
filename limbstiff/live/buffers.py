"""The buffers a live session keeps: the record of the current segment, the window of model steps
the checks look back over, and the band published at the last samples (the ``hindsight`` check).
Pure numpy."""

from __future__ import annotations

import numpy as np

from .checks import Hindsight, LiveChecks, live_checks


class Record:
    """SI arrays of the current segment (since the start or the last break): its last ``keep``
    samples at least (an identification looks no further back), so that a session of hours holds
    and copies minutes, not hours. Positions are counted from the segment's start (``total``)."""

    def __init__(self, keep: int):
        self.keep = max(int(keep), 1)
        self.angle = np.empty(4096)
        self.torque = np.empty(4096)
        self.n = 0              # samples held
        self.offset = 0         # samples dropped from the front

    @property
    def total(self) -> int:
        """Samples of the segment so far."""
        return self.offset + self.n

    def last(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the last ``k`` samples held (fewer when fewer are)."""
        first = max(0, self.n - k)
        return self.angle[first:self.n].copy(), self.torque[first:self.n].copy()

    def since(self, position: int) -> tuple[np.ndarray, np.ndarray]:
        """The samples from segment position ``position`` on (views)."""
        first = max(0, position - self.offset)
        return self.angle[first:self.n], self.torque[first:self.n]

    def append(self, angle, torque):
        end = self.n + len(angle)
        if end > len(self.angle):
            size = max(end, 2 * len(self.angle))
            self.angle = np.resize(self.angle, size)
            self.torque = np.resize(self.torque, size)
        self.angle[self.n:end] = angle
        self.torque[self.n:end] = torque
        self.n = end
        if self.n > 2 * self.keep:
            drop = self.n - self.keep
            self.angle[:self.keep] = self.angle[drop:self.n]
            self.torque[:self.keep] = self.torque[drop:self.n]
            self.offset += drop
            self.n = self.keep


class Window:
    """The model steps of the last window (rows of :data:`~limbstiff.live.kernel.OUT`), in a ring."""

    def __init__(self, capacity: int):
        self.ring = np.empty((max(capacity, 1), 10))
        self.pos = self.count = 0
        self.decimation = 0

    def add(self, rows: np.ndarray):
        size = len(self.ring)
        rows = rows[-size:]
        k = len(rows)
        first = min(k, size - self.pos)
        self.ring[self.pos:self.pos + first] = rows[:first]
        self.ring[:k - first] = rows[first:]
        self.pos = (self.pos + k) % size
        self.count = min(self.count + k, size)

    def tail(self, k: int) -> np.ndarray:
        """The last ``k`` rows held, in order."""
        return self.ring[(self.pos - k + np.arange(k)) % len(self.ring)]

    def checks(self, looked_back: Hindsight | None = None, recent: np.ndarray | None = None) -> LiveChecks:
        """:func:`~limbstiff.live.checks.live_checks` over the steps held."""
        rows = self.tail(self.count)
        return live_checks(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3] > 0, rows[:, 5], rows[:, 6], rows[:, 7],
                           rows[:, 8], recent=recent, looked_back=looked_back)


class PublishedBand:
    """The estimate and band published at the segment's last samples, by segment position, in a
    ring: rows of (stiffness, lo, hi, observable); NaN for samples not published (before an
    estimate, bridged)."""

    def __init__(self, capacity: int):
        self.rows = np.full((max(capacity, 1), 4), np.nan)
        self.end = 0            # the segment position after the last sample held

    def add(self, position: int, rows: np.ndarray | None, n: int = 0) -> None:
        """Samples from ``position`` on: the chain's output rows (:data:`~limbstiff.live.kernel.OUT`),
        or ``n`` samples without a band (``rows`` None)."""
        size = len(self.rows)
        k = n if rows is None else len(rows)
        start = position % size
        if k <= size - start:              # most chunks: one slice, no wrap
            self.rows[start:start + k] = np.nan if rows is None else rows[:, :4]
            self.end = position + k
            return
        skip = max(k - size, 0)
        start = (position + skip) % size
        first = min(k - skip, size - start)
        for into, take in ((slice(start, start + first), slice(skip, skip + first)),
                           (slice(0, k - skip - first), slice(skip + first, k))):
            self.rows[into] = np.nan if rows is None else rows[take, :4]
        self.end = position + k

    def between(self, first: int, end: int) -> tuple[np.ndarray, np.ndarray]:
        """lo and hi at positions ``first`` … ``end`` − 1, NaN where not informed or not held."""
        size = len(self.rows)
        out = np.full((end - first, 3), np.nan)
        held = max(first, self.end - size, 0)
        if held < end:
            out[held - first:] = self.rows[np.arange(held, end) % size, 1:]
        informed = out[:, 2] > 0
        return np.where(informed, out[:, 0], np.nan), np.where(informed, out[:, 1], np.nan)

    def recent(self, k: int) -> np.ndarray:
        """The stiffness published at the last ``k`` positions (NaN where none was, or not held)."""
        first = self.end - k
        out = np.full(k, np.nan)
        held = max(first, self.end - len(self.rows), 0)
        if held < self.end:
            out[held - first:] = self.rows[np.arange(held, self.end) % len(self.rows), 0]
        return out
