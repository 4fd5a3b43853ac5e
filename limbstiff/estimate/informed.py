"""Which samples the data inform, and the band where they do not.

Two criteria, both needed:

* motion (:func:`~limbstiff.estimate.observer.informed`): by the observer's forgetting, (8), the
  estimate rests on motion within a window of a few motion periods;
* the band (:func:`band_informed`): the Kalman model's posterior variance there is not many
  times its typical value (the observers' variance is the spread of their ratios, not a measure
  of information, and is not judged so).

A slow drift or tremor in a motion pause passes the first criterion, yet carries a tiny share of
the information (it goes with the deflection squared); the estimate there is carried across the
gap by the model of how the stiffness walks, which a co-contraction or an actuator's new
set-point in the pause does not follow.

Where a sample is not informed, :func:`uninformed_band` widens the band to what the trial's
informed band spans. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

#: A band wider than this multiple of its typical width (the median over the samples informed by
#: motion) is not informed: the local data give less than 1/3² ≈ 11 % of the information of the
#: trial's typical motion.
BAND_WIDENING = 3.0


def band_informed(variance: np.ndarray, observable: np.ndarray, *, widening: float = BAND_WIDENING) -> np.ndarray:
    """Samples informed by motion whose band is not ``widening`` times wider than typical.

    Parameters
    ----------
    variance : ndarray, shape (n,), (N·m/rad)²
        The Kalman model's posterior variance of the stiffness (inertia and damping taken as
        exact: their uncertainty is the same everywhere and says nothing about local information).
    observable : ndarray of bool, shape (n,)
        Informed by motion (:func:`~limbstiff.estimate.observer.informed`).
    widening : float
        Width ratio (standard deviations) above which a sample is not informed.

    Returns
    -------
    ndarray of bool, shape (n,)
        A new array; ``observable`` itself when fewer than 3 samples have a finite variance there.
    """
    observable = np.asarray(observable, dtype=bool)
    variance = np.asarray(variance, dtype=float)
    usable = observable & np.isfinite(variance)
    if np.count_nonzero(usable) < 3:
        return observable
    typical = float(np.median(variance[usable]))
    return observable & (variance <= widening ** 2 * typical)


def uninformed_band(lo: np.ndarray, hi: np.ndarray, observable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The band where no motion informs the estimate: at least the range the trial's informed band
    spans, so that it widens honestly where the data say nothing.

    The model's own band there extrapolates the stiffness walk at the rate fitted while the limb
    moved; a stiffness that changes while nothing moves (a co-contraction, an actuator's new
    set-point in a motion pause) is not bound by it. Informed samples keep the model's band.

    Parameters
    ----------
    lo, hi : ndarray, shape (n,), N·m/rad (N/m)
    observable : ndarray of bool, shape (n,)

    Returns
    -------
    lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        New arrays; unchanged when no sample (or every sample) is informed.
    """
    if observable.all() or not observable.any():
        return lo, hi
    lowest, highest = float(np.min(lo[observable])), float(np.max(hi[observable]))
    return (np.where(observable, lo, np.minimum(lo, lowest)), np.where(observable, hi, np.maximum(hi, highest)))
