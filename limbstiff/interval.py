"""A value with its central credible interval: how limbstiff reports every estimated quantity."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Interval:
    """A value with its central credible interval.

    Parameters
    ----------
    median, lo, hi : float
        Median and bounds, in the quantity's SI unit.
    """

    median: float
    lo: float
    hi: float

    @classmethod
    def fixed(cls, value: float) -> "Interval":
        """A value known exactly (given by the user or the protocol)."""
        return cls(float(value), float(value), float(value))

    @classmethod
    def of_draws(cls, draws: np.ndarray, level: float) -> "Interval":
        """Median and central ``level`` interval of samples (n,)."""
        lo, med, hi = np.quantile(draws, [0.5 - level / 2, 0.5, 0.5 + level / 2])
        return cls(float(med), float(lo), float(hi))

    @property
    def is_fixed(self) -> bool:
        """True for a value given, not estimated (zero width)."""
        return self.lo == self.hi

    def to_dict(self) -> dict:
        return {"median": self.median, "lo": self.lo, "hi": self.hi}
