"""Movement cycles of a recording: where each starts, each sample's phase, the ensemble mean.

Labs repeat one movement tens to hundreds of times with small perturbations on top. A cycle is
cut either at fixed length (``period_s`` from the first sample or from ``start_s``) or at the
rising edges of a trigger column. Cycles of unequal length are time-normalised: the phase of a
sample in cycle k is (t − t_k)/(t_{k+1} − t_k), linear in time from 0 at the cycle's start to 1
at the next cycle's start, so each cycle is stretched or shrunk evenly to one common length.
The part of the torque and the angle that repeats in every cycle (the movement itself, the
torque it needs) is the ensemble mean at each phase; what is left are the perturbations'
responses, from which the stiffness at each phase is identified (the ensemble methods of the
Kearney lab: Ludvig & Kearney, IEEE TBME 2007; Guarín & Kearney, IEEE TNSRE 2018).
Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Fewest whole cycles an ensemble analysis takes: the phase's curve pools them, and its
#: resolution is chosen by leaving whole cycles out (:data:`limbstiff.heldout.FOLDS` of them at least).
MIN_CYCLES = 5
#: Rising edges closer than this share of the median spacing to the previous edge are the same
#: event (a trigger that bounces, a pulse sampled twice).
DEBOUNCE_SHARE = 0.25
#: Phase bins of the ensemble mean: at most this many, at least four samples per bin on the
#: shortest cycle.
MEAN_BINS = 200


@dataclass(frozen=True)
class CycleSplit:
    """The cycles of a recording.

    Parameters
    ----------
    starts : ndarray of int, shape (C + 1,)
        The first sample of each cycle, then the sample that ends the last one (the next start).
    how : str
        How they were found, in words (``"every 1.5 s from 0 s"``, ``"rising edges of 'trigger'"``).
    """

    starts: np.ndarray
    how: str

    @property
    def n_cycles(self) -> int:
        return len(self.starts) - 1

    @property
    def span(self) -> slice:
        """The samples covered by whole cycles."""
        return slice(int(self.starts[0]), int(self.starts[-1]))

    def lengths(self) -> np.ndarray:
        """Samples per cycle, shape (C,)."""
        return np.diff(self.starts)

    def cycle_of(self, n: int) -> np.ndarray:
        """The cycle of each of ``n`` samples (from the recording's first), −1 outside whole cycles."""
        out = np.searchsorted(self.starts, np.arange(n), side="right") - 1
        out[(out < 0) | (out >= self.n_cycles)] = -1
        return out

    def phase_of(self, n: int) -> np.ndarray:
        """The phase (0–1) of each of ``n`` samples, linear in time within its cycle; NaN outside."""
        cycle = self.cycle_of(n)
        inside = cycle >= 0
        out = np.full(n, np.nan)
        k = np.arange(n)[inside]
        start, length = self.starts[cycle[inside]], np.diff(self.starts)[cycle[inside]]
        out[inside] = (k - start) / length
        return out

    def shifted(self, offset: int) -> "CycleSplit":
        """The same cycles counted from sample ``offset`` (a recording cropped there)."""
        return CycleSplit(self.starts - offset, self.how)


def by_period(n: int, *, sample_period: float, period_s: float, start_s: float = 0.0) -> CycleSplit:
    """Cycles of ``period_s`` seconds from ``start_s`` (time from the first sample), whole ones only.

    Parameters
    ----------
    n : int
        Samples of the recording.
    sample_period : float, s
    period_s, start_s : float, s
    """
    starts = np.round((start_s + period_s * np.arange(int((n * sample_period - start_s) / period_s) + 1))
                      / sample_period).astype(int)
    starts = starts[starts <= n]
    return CycleSplit(starts, f"every {period_s:g} s from {start_s:g} s")


def rising_edges(marker: np.ndarray) -> np.ndarray:
    """Samples where a trigger column rises through the midway between its low and high levels
    (its least and greatest values: a pulse may be under 1 % of the samples), bounces
    (:data:`DEBOUNCE_SHARE`) removed. Shape (e,)."""
    x = np.asarray(marker, dtype=float)
    low, high = float(np.min(x)), float(np.max(x))
    if not high > low:
        return np.zeros(0, dtype=int)
    above = x >= (low + high) / 2
    edges = np.flatnonzero(above[1:] & ~above[:-1]) + 1
    if above[0]:
        edges = np.concatenate([[0], edges])
    if len(edges) < 3:
        return edges
    gap = DEBOUNCE_SHARE * np.median(np.diff(edges))
    kept = [edges[0]]
    for e in edges[1:]:
        if e - kept[-1] >= gap:
            kept.append(e)
    return np.asarray(kept)


def by_marker(marker: np.ndarray, *, header: str) -> CycleSplit:
    """Cycles from one rising edge of ``marker`` (n,) to the next (:func:`rising_edges`)."""
    return CycleSplit(rising_edges(marker), f"rising edges of '{header}'")


def ensemble_mean(values: np.ndarray, phase: np.ndarray, *, bins: int) -> np.ndarray:
    """The mean over cycles of ``values`` (n,) at each sample's phase (n,): averaged in ``bins``
    equal phase bins, interpolated linearly (periodically) between the bins' mean phases (not their
    centres: the samples of a bin need not straddle its centre, and a signal's slope times that
    offset would be left in every cycle); NaN where the phase is NaN."""
    inside = np.isfinite(phase)
    ph = phase[inside]
    which = np.minimum((ph * bins).astype(int), bins - 1)
    count = np.bincount(which, minlength=bins)
    good = count > 0
    mean = np.bincount(which, weights=values[inside], minlength=bins)[good] / count[good]
    at = np.bincount(which, weights=ph, minlength=bins)[good] / count[good]
    out = np.full(len(values), np.nan)
    out[inside] = np.interp(ph, at, mean, period=1.0)
    return out


def mean_bins(split: CycleSplit) -> int:
    """Phase bins of the ensemble mean: :data:`MEAN_BINS` at most, four samples each on the
    shortest cycle at least."""
    return int(max(4, min(MEAN_BINS, split.lengths().min() // 4)))
