"""Physics of the unmodelled effects, written once for the simulator and the diagnosis.

:mod:`limbstiff.simulate` adds these effects to a simulated joint; :mod:`limbstiff.diagnosis` fits
them to a recording. Both take the primitives below from here, so that the play of a
backlash, the Dahl hysteresis, a delayed channel, Coulomb friction and gravity are the same
physics in both. Where the two deliberately evaluate an effect differently, both forms are
here side by side and their docstrings say why.

Functions that serve the simulator's scalar RK4 loop as well as arrays take ``lib``
(:mod:`math` or :mod:`numpy`). Pure numpy: no I/O, no state.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np


def play(x: np.ndarray, width: float) -> np.ndarray:
    """Play (backlash) operator of total ``width``.

    The output follows the input only once the input has crossed a dead band ±width/2 around
    it; it starts at x[0].

    Parameters
    ----------
    x : ndarray, shape (n,)
        Input (the joint angle, rad, or any signal).
    width : float
        Total width of the dead band, in the unit of ``x``.

    Returns
    -------
    ndarray, shape (n,)
    """
    half = 0.5 * width
    out, o = np.empty(len(x)), float(x[0])
    for k, xi in enumerate(np.asarray(x, dtype=float).tolist()):
        if xi - o > half:
            o = xi - half
        elif o - xi > half:
            o = xi + half
        out[k] = o
    return out


def dahl_rate(velocity: float, state: float, amplitude: float,
              characteristic_angle: float) -> float:
    """Time derivative of the Dahl hysteresis torque: dz/dt = (F·ẏ − |ẏ|·z)/y_c.

    The form the simulator integrates with the true motion inside the equation of motion
    (torque drive, scalar floats).

    Parameters
    ----------
    velocity : float
        ẏ, rad/s.
    state : float
        z, the hysteresis torque, N·m.
    amplitude : float
        F, N·m: z saturates at ±F.
    characteristic_angle : float
        y_c, rad: the angle over which z saturates after a reversal.

    Returns
    -------
    float, N·m/s
    """
    return (amplitude * velocity - abs(velocity) * state) / characteristic_angle


def dahl_along(angle: np.ndarray, amplitude: float, characteristic_angle: float) -> np.ndarray:
    """Dahl hysteresis torque along a prescribed angle, exact for monotone steps.

    dz/dy = (F − sgn(ẏ)·z)/y_c, z(0) = 0, so on a monotone step Δy the torque relaxes
    exponentially towards ±F over the angle y_c: z ← s + (z − s)·exp(−|Δy|/y_c), s = ±F.

    The simulator's form (position drive). It is the same solution as :func:`dahl` (times F)
    and differs from it only by rounding; it is kept so that seeded simulated trials stay
    exactly as they were generated, while the diagnosis, which evaluates the loop for every
    shape of its grid on every trial, uses the vectorised recursion of :func:`dahl`.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad
    amplitude : float
        F, N·m.
    characteristic_angle : float
        y_c, rad.

    Returns
    -------
    ndarray, shape (n,), N·m
    """
    dy = np.diff(angle)
    decay = np.exp(-np.abs(dy) / characteristic_angle).tolist()
    target = (np.sign(dy) * amplitude).tolist()
    out, z = [0.0], 0.0
    for s, e in zip(target, decay):
        z = s + (z - s) * e
        out.append(z)
    return np.array(out)


def dahl(angle: np.ndarray, characteristic_angle: float) -> np.ndarray:
    """Dahl hysteresis state of unit amplitude along an angle path (exact for monotone steps).

    dz/dy = (sgn(ẏ) − z)/y_c, z(0) = 0: after each reversal the state relaxes exponentially
    towards ±1 over the angle y_c, run as the linear recursion z ← a·z + (1 − a)·sgn(Δy) with
    a = exp(−|Δy|/y_c). The diagnosis's form; see :func:`dahl_along` for the simulator's.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad
    characteristic_angle : float
        y_c, rad.

    Returns
    -------
    ndarray, shape (n,), dimensionless
    """
    # imported here so that the simulator does not load the estimators
    from .estimate.observer import linear_recursion

    dy = np.diff(angle, prepend=angle[0])
    a = np.exp(-np.abs(dy) / characteristic_angle)
    return linear_recursion(a, (1.0 - a) * np.sign(dy))


def delay_signal(t: np.ndarray, x: np.ndarray, delay: float,
                 before: float | None = None) -> np.ndarray:
    """x(t − delay) by linear interpolation (a negative ``delay`` advances the signal).

    Parameters
    ----------
    t : ndarray, shape (n,), s
        Increasing sample times.
    x : ndarray, shape (n,)
    delay : float, s
    before : float, optional
        Value before the first sample (default: the first value held); after the last
        sample the last value is held.

    Returns
    -------
    ndarray, shape (n,)
    """
    return np.interp(t - delay, t, x, left=before)


def coulomb(velocity, smoothing_velocity: float, lib: ModuleType = np):
    """Coulomb friction per unit friction torque, tanh(ẏ/v_ε): ±1 except near ẏ = 0.

    Parameters
    ----------
    velocity : float or ndarray, rad/s
    smoothing_velocity : float
        v_ε, rad/s.
    lib : module
        :mod:`math` for floats, :mod:`numpy` for arrays.

    Returns
    -------
    float or ndarray, dimensionless
    """
    return lib.tanh(velocity / smoothing_velocity)


def gravity(angle, angle_offset: float, lib: ModuleType = np):
    """Gravity torque per unit mgl on an unbalanced segment, −sin(y + θ₀).

    On the left-hand side of the equation of motion, so it destabilises about the upright
    position (θ₀: the angle from upright at y = 0).

    Parameters
    ----------
    angle : float or ndarray, rad
    angle_offset : float
        θ₀, rad.
    lib : module
        :mod:`math` for floats, :mod:`numpy` for arrays.

    Returns
    -------
    float or ndarray, dimensionless
    """
    return -lib.sin(angle + angle_offset)
