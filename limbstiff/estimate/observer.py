"""The stiffness observer of Grioli & Bicchi (RSS 2010), Sec. III-B.

Update law (7) with the prediction f̂̇ = m·y⃛ + b·ÿ + σ̂·ẏ:

    dσ̂/dt = α·(ḟ − f̂̇)·sgn(ẏ) = −α·|ẏ|·σ̂ + α·sgn(ẏ)·r,      r = ḟ − m·y⃛ − b·ÿ

(the *external-torque variant*; in the *direct variant* f is measured on the elastic element
and r = ḟ). The law is linear in σ̂, so over each sample it is a first-order recursion
σ̂[k] = a[k]·σ̂[k−1] + c[k]. Two discretisations are offered:

* ``exact``: the ODE solved exactly over (t[k−1], t[k]] with the sample-k values held:
  a = exp(−α·|ẏ|·Ts) ∈ (0, 1] and c = (1 − a)·r/ẏ — stable for every gain and period, and
  with a large gain it tends to the instantaneous ratio r/ẏ with no lag;
* ``euler``: forward Euler, a = 1 − α·|ẏ|·Ts, c = α·Ts·sgn(ẏ)·r — diverges once
  α·|ẏ|·Ts > 2; kept to compare with.

Where ẏ = 0 (or below the velocity noise level) a = 1 and c = 0: the estimate is held.
The law is written once, in :func:`recursion_coefficients`; the recursion itself runs compiled
(:mod:`limbstiff.statespace.kernels`), or as a blocked NumPy scan (:mod:`limbstiff.estimate.scan`)
when numba is disabled. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from ..statespace import kernels
from . import scan

DISCRETISATIONS = ("exact", "euler")


def recursion_coefficients(velocity: np.ndarray, drive: np.ndarray, *, observer_gain: float,
                           sample_period: float, discretisation: str = "exact",
                           velocity_threshold: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients a[k], c[k] of σ̂[k] = a[k]·σ̂[k−1] + c[k].

    Parameters
    ----------
    velocity : ndarray, shape (n,), rad/s (m/s)
        ẏ.
    drive : ndarray, shape (n,), N·m/s (N/s)
        r = ḟ − m·y⃛ − b·ÿ (external variant) or ḟ of the elastic element (direct variant).
    observer_gain : float, 1/rad (1/m)
        α of eq. (7).
    sample_period : float, s
    discretisation : {"exact", "euler"}
    velocity_threshold : float, rad/s (m/s)
        Speeds at or below it count as ẏ = 0 (no update).

    Returns
    -------
    a, c : ndarray, shape (n,)
    """
    if discretisation not in DISCRETISATIONS:
        raise ValueError(f"discretisation must be one of {DISCRETISATIONS}, not {discretisation!r}")
    speed = np.abs(velocity)
    moving = speed > velocity_threshold
    sign = np.where(moving, np.sign(velocity), 0.0)
    g = observer_gain * sample_period * speed * moving
    if discretisation == "euler":
        return 1.0 - g, observer_gain * sample_period * sign * drive
    a = np.exp(-g)
    with np.errstate(divide="ignore", invalid="ignore"):
        # (1 − a)/|ẏ|, written with expm1 so that it stays exact as |ẏ| → 0
        weight = np.where(moving, -np.expm1(-g) / np.where(moving, speed, 1.0), 0.0)
    return a, weight * sign * drive


def linear_recursion(a: np.ndarray, c: np.ndarray, initial: float = 0.0) -> np.ndarray:
    """Run x[k] = a[k]·x[k−1] + c[k] with x[−1] = ``initial``.

    Parameters
    ----------
    a, c : ndarray, shape (n,)
    initial : float

    Returns
    -------
    ndarray, shape (n,)
    """
    a = np.ascontiguousarray(a, dtype=float)
    c = np.ascontiguousarray(c, dtype=float)
    if not kernels.COMPILED and a.size and np.min(a) >= 0.0 and np.max(a) <= 1.0:
        return scan.linear_recursion(a, c, initial)      # vectorised NumPy, no loop over samples
    return kernels.linear_recursion(a, c, float(initial))


def observe(velocity: np.ndarray, drive: np.ndarray, *, observer_gain: float, sample_period: float,
            discretisation: str = "exact", initial: float = 0.0,
            velocity_threshold: float = 0.0) -> np.ndarray:
    """Stiffness estimate σ̂ of update law (7), sample by sample.

    Parameters
    ----------
    velocity : ndarray, shape (n,), rad/s (m/s)
    drive : ndarray, shape (n,), N·m/s (N/s)
        See :func:`recursion_coefficients`.
    observer_gain : float, 1/rad (1/m)
    sample_period : float, s
    discretisation : {"exact", "euler"}
    initial : float, N·m/rad (N/m)
        σ̂ before the first sample.
    velocity_threshold : float, rad/s (m/s)

    Returns
    -------
    ndarray, shape (n,), N·m/rad (N/m)
    """
    a, c = recursion_coefficients(velocity, drive, observer_gain=observer_gain,
                                  sample_period=sample_period, discretisation=discretisation,
                                  velocity_threshold=velocity_threshold)
    return linear_recursion(a, c, initial)


def external_drive(torque_rate: np.ndarray, acceleration: np.ndarray, jerk: np.ndarray, *,
                   inertia, damping) -> np.ndarray:
    """r = ḟ − m·y⃛ − b·ÿ, the input of the external-torque variant.

    Parameters
    ----------
    torque_rate : ndarray, shape (n,), N·m/s
        ḟ of the external torque.
    acceleration : ndarray, shape (n,), rad/s²
    jerk : ndarray, shape (n,), rad/s³
    inertia : float, kg·m²
    damping : float or ndarray, shape (n,), N·m·s/rad
        Constant damping, or the generalized damping b(d) along the trajectory (Sec. II).

    Returns
    -------
    ndarray, shape (n,), N·m/s
    """
    return torque_rate - inertia * jerk - damping * acceleration


def informed(velocity: np.ndarray, *, observer_gain: float, sample_period: float, window: float,
             velocity_threshold: float = 0.0, forgotten: float = 0.05) -> np.ndarray:
    """Where the estimate is informed by recent motion.

    By (8), the part of σ̂ that predates an interval decays as exp(−α·∫|ẏ|dt) over it. A
    sample counts as observable when, over the preceding ``window``, that factor fell below
    ``forgotten``: the estimate then rests on motion within the window, not on a guess or on
    data older than the window.

    Parameters
    ----------
    velocity : ndarray, shape (n,), rad/s (m/s)
    observer_gain : float, 1/rad (1/m)
    sample_period : float, s
    window : float, s
    velocity_threshold : float, rad/s (m/s)
    forgotten : float
        Remaining weight of older information below which the estimate counts as informed.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    speed = np.where(np.abs(velocity) > velocity_threshold, np.abs(velocity), 0.0)
    path = np.concatenate([[0.0], np.cumsum(speed * sample_period)])
    lag = max(1, int(round(window / sample_period)))
    k = np.arange(1, len(velocity) + 1)
    recent = path[k] - path[np.maximum(k - lag, 0)]
    return observer_gain * recent > -np.log(forgotten)


def informed_samples(observable: np.ndarray) -> np.ndarray:
    """The samples a trial-level statistic is taken over: the informed ones, or all of them when
    none is (bool, shape (n,))."""
    observable = np.asarray(observable, dtype=bool)
    return observable if observable.any() else np.ones_like(observable)
