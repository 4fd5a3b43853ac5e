"""The stiffness's band, and the limb's stiffness when a compliant coupling was found.

The band carries the estimator's own variance and the uncertainty of the model's linear
coefficients (m, b, the effects' amplitudes, a curve's weights) through the estimate's
sensitivity to them, and the spread of the alternatives to the chosen model of comparable
evidence (:class:`ModelForm`); with a coupling the one-body course and its band are those of the
springs in series, which :meth:`CouplingFit.limb_stiffness` undoes. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from .coupling import MAX_CORRECTION, CouplingFit
from .estimate.estimators import Estimate
from .estimate.informed import uninformed_band


def half_width(estimate: Estimate, covariance: np.ndarray | None, level: float) -> np.ndarray:
    """Half the width of the central ``level`` band of the one-body course, shape (n,), N·m/rad (N/m):
    the estimator's variance with ``covariance`` (p, p) of the first p coefficients carried."""
    return float(stats.norm.ppf(0.5 + level / 2)) * np.sqrt(np.maximum(estimate.variance_with(covariance), 0.0))


@dataclass(frozen=True)
class ModelForm:
    """Alternatives to the chosen model (:mod:`limbstiff.effects.model_form`).

    Parameters
    ----------
    weights : ndarray, shape (j,)
        Each alternative's posterior weight; the chosen model holds 1 − their sum.
    changes : ndarray, shape (j, n)
        Each one's course less the chosen one's on the samples, N·m/rad (N/m).
    """

    weights: np.ndarray
    changes: np.ndarray

    def spread(self) -> np.ndarray:
        """Root mean square over the models of the course less the chosen one's, shape (n,), N·m/rad
        (N/m): the mixture's spread about the chosen course (its own offset included)."""
        return np.sqrt(self.weights @ self.changes ** 2)

    def draws(self, rng: np.random.Generator, n_draws: int, index: np.ndarray) -> np.ndarray:
        """Each draw's model (the chosen one with its weight) as its change at the samples
        ``index`` (c,), shape (n_draws, c): the mixture of the models' draws."""
        p = np.concatenate([[max(1.0 - float(self.weights.sum()), 0.0)], self.weights])
        rows = np.vstack([np.zeros(len(index)), self.changes[:, index]])
        return rows[rng.choice(len(p), size=n_draws, p=p / p.sum())]


def stiffness_band(estimate: Estimate, covariance: np.ndarray | None, coupling: CouplingFit | None,
                   informed: np.ndarray, level: float,
                   form: ModelForm | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stiffness and its ``level`` band (:func:`half_width`, with the alternatives' spread
    ``form`` added in quadrature at the level's quantile), the limb's when a coupling was found
    (:func:`limb_stiffness`), unbounded where uninformed; each shape (n,), N·m/rad (N/m)."""
    half = half_width(estimate, covariance, level)
    if form is not None:
        half = np.hypot(half, float(stats.norm.ppf(0.5 + level / 2)) * form.spread())
    stiffness, lo, hi = limb_stiffness(coupling, estimate.stiffness, estimate.stiffness - half,
                                       estimate.stiffness + half)
    lo, hi = uninformed_band(lo, hi, informed)
    return stiffness, lo, hi


def model_form_share(estimate: Estimate, covariance: np.ndarray | None, form: ModelForm | None,
                     informed: np.ndarray) -> float:
    """Share of the band's variance that is the alternatives' spread ``form``, median over the
    samples ``informed`` (indices or mask, shape (n,)); 0 without alternatives."""
    if form is None:
        return 0.0
    own = np.maximum(estimate.variance_with(covariance), 0.0)[informed]
    spread = form.spread()[informed] ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        share = spread / (own + spread)
    share = share[np.isfinite(share)]
    return float(np.median(share)) if len(share) else 0.0


def limb_stiffness(coupling: CouplingFit | None, stiffness, lo, hi):
    """The limb's stiffness and band when a coupling was found.

    With a coupling the one-body estimate is that of the springs in series
    (:meth:`CouplingFit.limb_stiffness` undoes it); unchanged without one, when the correction at
    the median stiffness exceeds :data:`MAX_CORRECTION`, or when the estimate reaches k_c somewhere.

    Parameters
    ----------
    coupling : CouplingFit or None
        The coupling found in the trial, if any.
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        The one-body stiffness and its band.

    Returns
    -------
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        The limb's, or the arguments themselves when unchanged; ``hi`` is inf where the limb's is
        unbounded.
    """
    if coupling is None or not coupling.found:
        return stiffness, lo, hi
    if not coupling.correction(float(np.median(stiffness))) <= MAX_CORRECTION:
        return stiffness, lo, hi
    limb = [coupling.limb_stiffness(x) for x in (stiffness, lo, hi)]
    if not np.all(np.isfinite(limb[0])):
        return stiffness, lo, hi
    return limb[0], limb[1], np.where(np.isfinite(limb[2]), limb[2], np.inf)
