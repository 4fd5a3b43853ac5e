"""The model's linear coefficients by name: m, b, the effects' amplitudes, a curve's weights.

Every coefficient that enters the measurement linearly (:mod:`limbstiff.statespace.linear`) has a
name — ``inertia``, ``damping``, then each effect's and each curve weight's
(:class:`~limbstiff.mechanics.effect_terms.EffectTerms` ``names``) — and a step that needs some of
them asks for them by name, not by position in the vector. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .mechanics.identification import Identification

#: The names of the mechanical coefficients, first in every model.
MECHANICS = ("inertia", "damping")


@dataclass(frozen=True)
class Coefficients:
    """Named linear coefficients with their joint uncertainty.

    Parameters
    ----------
    names : tuple of str
        ``inertia``, ``damping``, then the effects' and the curve's terms, in the model's order
        (that of the estimate's sensitivity rows).
    values : ndarray, shape (p,)
        Posterior medians (given values where given), SI units.
    covariance : ndarray, shape (p, p)
        Their joint covariance (zero where given).
    draws : ndarray, shape (n_draws, p), or None
        Joint posterior draws, given values held fixed; None without a posterior.
    """

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    draws: np.ndarray | None = None

    @classmethod
    def of(cls, ident: Identification) -> Coefficients:
        """The coefficients of an identification, named."""
        names = MECHANICS + tuple(e.name for e in ident.effects + ident.basis)
        return cls(names, ident.coefficients, ident.coefficient_covariance, ident.coefficient_draws)

    def positions(self, names: Sequence[str]) -> np.ndarray:
        """Where ``names`` stand in :attr:`names` (and in the estimate's sensitivity rows), shape (k,)."""
        return np.array([self.names.index(name) for name in names], dtype=int)

    def values_of(self, names: Sequence[str]) -> np.ndarray:
        """The medians of ``names``, shape (k,)."""
        return self.values[self.positions(names)]

    def rows_of(self, sensitivity: np.ndarray) -> np.ndarray:
        """The rows (p, n) of an estimate's ``sensitivity`` that answer to these coefficients: the
        estimate's rows follow the model's order (:attr:`names`), a probe's row after them."""
        return sensitivity[:len(self.names)]
