"""How the simulator draws each unmodelled effect: what it adds to the equation of motion or the record.

Two kinds (an :class:`~limbstiff.effects.registry.Effect`'s ``kind``):

* ``dynamics`` — a torque (or a changed inertia/damping) in the equation of motion
  (:class:`DynamicsTerm`); with a position drive the torque simply adds to the recorded torque;
* ``measurement`` — changes what is recorded (angle or torque channel), not the motion
  (:class:`Measurement`).

Each ``*_term`` or ``*_record`` function builds one effect from its parameters (a mapping of
floats, SI units); the registry (:data:`limbstiff.effects.registry.EFFECTS`) names them, with their
default sizes. The physics shared with the model (play, Dahl hysteresis, channel delay, Coulomb
friction, gravity) is in :mod:`limbstiff.unmodelled`. Two effects are deliberately simulated in
another form than the model fits them: the reflex reads the true delayed velocity (analytic for a
position drive, the integrated history for a torque drive) where the model can only interpolate
the filtered one, and sensor drift is *drawn* here (a random walk, :func:`drift`). Pure numpy/scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from ..unmodelled import coulomb, dahl_along, dahl_rate, delay_signal, gravity, play

#: Scales of the ``elbow`` scenario at its defaults (seed 0): the reference for
#: :attr:`Effect.defaults <limbstiff.effects.registry.Effect.defaults>`.
REFERENCE_SCALES: Mapping[str, float] = {
    "torque": 0.1729, "velocity": 0.1773, "quartic_velocity": 0.2367, "angle": 0.01286,
    "stiffness": 6.0}


@dataclass(frozen=True)
class DynamicsTerm:
    """What an unmodelled effect adds to the equation of motion.

    Parameters
    ----------
    torque : callable (y, v, z, vd, lib) -> N·m, optional
        Effect torque e on the left-hand side (it resists motion when positive with ẏ);
        ``z`` is the effect's internal state, ``vd`` the velocity ẏ(t − delay).
    state_rate : callable (y, v, z) -> dz/dt, optional
        Internal state dynamics, scalar floats (torque drive).
    state_along : callable (y) -> z, optional
        The same state integrated along a prescribed angle array (position drive).
    delay : float
        δ, s, of the delayed velocity (0 when not used).
    inertia_scale, damping_scale : float
        True inertia and damping as multiples of the nominal ones.
    max_stiffness, max_damping : float
        What the effect adds to the step-size bounds.
    """

    torque: Callable | None = None
    state_rate: Callable | None = None
    state_along: Callable | None = None
    delay: float = 0.0
    inertia_scale: float = 1.0
    damping_scale: float = 1.0
    max_stiffness: float = 0.0
    max_damping: float = 0.0


#: No effect: the nominal joint.
NO_EFFECT = DynamicsTerm()


@dataclass(frozen=True)
class Measurement:
    """A change of the recorded channels: ``apply(time, angle, torques, rng)``.

    ``torques`` maps channel names (``torque``, ``elastic_torque``) to arrays; ``apply``
    returns the new ``(angle, torques)``.
    """

    apply: Callable


def _positive(params: Mapping[str, float], *keys: str) -> None:
    for key in keys:
        if not params[key] > 0:
            raise ValueError(f"effect parameter '{key}' must be positive, got {params[key]}")


# --- dynamics -------------------------------------------------------------------------------

def coulomb_term(p):
    """F_c·tanh(ẏ/v_ε): ``friction_torque`` F_c, N·m; ``smoothing_velocity`` v_ε, rad/s."""
    _positive(p, "smoothing_velocity")
    fc, ve = p["friction_torque"], p["smoothing_velocity"]
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: fc * coulomb(v, ve, lib),
                        max_damping=abs(fc) / ve)


def quadratic_term(p):
    """c·ẏ|ẏ|: ``coefficient`` c, N·m·s²/rad²."""
    c = p["coefficient"]
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: c * v * abs(v))


def hysteresis_term(p):
    """The Dahl state z as a torque: ``amplitude`` F, N·m; ``characteristic_angle`` y_c, rad."""
    _positive(p, "characteristic_angle")
    f, yc = p["amplitude"], p["characteristic_angle"]
    return DynamicsTerm(
        torque=lambda y, v, z, vd, lib: z,
        state_rate=lambda y, v, z: dahl_rate(v, z, f, yc),
        state_along=lambda angle: dahl_along(angle, f, yc),
        max_stiffness=abs(f) / yc)


def reflex_term(p):
    """direction·g·[direction·ẏ(t − delay)]₊: ``gain`` g, N·m·s/rad; ``delay``, s; ``direction`` ±1."""
    _positive(p, "delay")
    g, d, s = p["gain"], p["delay"], p["direction"]
    if s not in (1.0, -1.0):
        raise ValueError(f"effect parameter 'direction' must be 1 or -1, got {s}")
    # s·g·[s·ẏ(t − d)]₊ written without max() so that it works on floats and arrays.
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: 0.5 * g * (vd + s * abs(vd)), delay=d)


def gravity_term(p):
    """−mgl·(sin(y + angle_offset) − sin(angle_offset)): ``mgl``, N·m; ``angle_offset``, rad."""
    mgl, off = p["mgl"], p["angle_offset"]
    bias = mgl * math.sin(off)
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: bias + mgl * gravity(y, off, lib),
                        max_stiffness=abs(mgl))


def scale_error(key):
    """The builder of a true inertia or damping (``key``: ``inertia_scale``, ``damping_scale``) of
    1 + ``fraction`` times the nominal one."""
    def build(p):
        if not p["fraction"] > -1:
            raise ValueError(f"effect parameter 'fraction' must be > -1, got {p['fraction']}")
        return DynamicsTerm(**{key: 1.0 + p["fraction"]})
    return build


# --- measurement ----------------------------------------------------------------------------

def backlash_record(p):
    """The recorded angle through a play of total ``width``, rad."""
    _positive(p, "width")
    w = p["width"]
    return Measurement(lambda t, angle, torques, rng: (play(angle, w), torques))


def time_delay_record(p):
    """The torque channels recorded ``delay`` s late."""
    d = p["delay"]
    return Measurement(lambda t, angle, torques, rng: (
        angle, {k: delay_signal(t, x, d) for k, x in torques.items()}))


def drift(t: np.ndarray, rng: np.random.Generator, slope: float, random_walk: float,
          knot_interval: float) -> np.ndarray:
    """Sensor drift: slope·t plus a random walk, smooth between knots.

    The random walk (intensity ``random_walk``, unit/√s) is drawn at knots ``knot_interval``
    s apart and joined by a cubic spline, so it has no content above ~1/(2·knot_interval) Hz.
    A draw, not a model to fit: the model holds a slow drift of the torque offset as a walk of the
    elastic torque.

    Returns
    -------
    ndarray, shape (n,)
    """
    from scipy.interpolate import CubicSpline

    t0, t1 = float(t[0]), float(t[-1])
    n_knots = max(2, math.ceil((t1 - t0) / knot_interval) + 1)
    knots = t0 + knot_interval * np.arange(n_knots)
    steps = rng.normal(0.0, random_walk * math.sqrt(knot_interval), size=n_knots - 1)
    walk = np.concatenate([[0.0], np.cumsum(steps)])
    return slope * (t - t0) + CubicSpline(knots, walk)(t)


def sensor_drift_record(p):
    """The torque channels plus a drawn drift (:func:`drift`): ``slope``, ``random_walk``, ``knot_interval``."""
    _positive(p, "knot_interval")
    return Measurement(lambda t, angle, torques, rng: (angle, {
        k: x + drift(t, rng, p["slope"], p["random_walk"], p["knot_interval"])
        for k, x in torques.items()}))
