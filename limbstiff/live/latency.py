"""The live loop's latency, kept in constant memory: log-spaced histograms, their quantiles.

A session of hours at one-sample chunks would otherwise keep millions of values. Bins 0.5 % wide
(1 ns to 100 s) put every quantile within 0.5 % of the value's; the maximum is kept exactly.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

#: Bin edges, s: 0.5 % apart from 1 ns to 100 s.
EDGES = tuple(float(x) for x in np.exp(np.arange(math.log(1e-9), math.log(100.0), math.log(1.005))))


class Histogram:
    """Counts of values (s) in the bins of :data:`EDGES`, and the largest value."""

    def __init__(self):
        self.counts = np.zeros(len(EDGES) + 1, dtype=np.int64)
        self.n = 0
        self.largest = -math.inf

    def add(self, value: float) -> None:
        self.counts[bisect.bisect_right(EDGES, value)] += 1
        self.n += 1
        if value > self.largest:
            self.largest = value

    def quantile(self, q: float) -> float:
        """The value below which a share ``q`` of the values lie (the bin's upper edge, s)."""
        rank = q * self.n
        k = int(np.searchsorted(np.cumsum(self.counts), rank, side="left"))
        return min(EDGES[min(k, len(EDGES) - 1)], self.largest)

    def summary(self, scale: float) -> dict | None:
        """``median``, ``p99``, ``p99_9``, ``max`` (times ``scale``) and ``chunks``; None when empty."""
        if not self.n:
            return None
        return {"median": self.quantile(0.5) * scale, "p99": self.quantile(0.99) * scale,
                "p99_9": self.quantile(0.999) * scale, "max": self.largest * scale, "chunks": self.n}


class Latency:
    """Per chunk: processing per sample (wall and this thread's CPU) and the delay from the chunk's
    last input time stamp to its publication."""

    def __init__(self):
        self.processing, self.processing_cpu, self.delay = Histogram(), Histogram(), Histogram()

    def summary(self) -> dict:
        return {"processing_us_per_sample": self.processing.summary(1e6),
                "processing_cpu_us_per_sample": self.processing_cpu.summary(1e6),
                "end_to_end_ms": self.delay.summary(1e3)}
