"""Unmodelled effects: what a real joint or set-up adds to the nominal m-b-σ model.

Two kinds:

* ``dynamics`` — a torque (or a changed inertia/damping) in the equation of motion; with a
  position drive the torque simply adds to the recorded torque;
* ``measurement`` — changes what is recorded (angle or torque channel), not the motion.

Default sizes follow the scenario: each is a fraction of the scenario's typical scales
(``torque``: RMS external torque, N·m; ``velocity``: RMS ẏ, rad/s; ``angle``: RMS angle
about its mean, rad; ``stiffness``: smallest σ, N·m/rad — see ``Scenario.scales``), so an
effect is clearly visible but physiological whatever the joint. The fractions and the
reasoning are given for each effect below; ``SimulatedEffect.defaults`` shows the values for the
human elbow (``REFERENCE_SCALES``). Sizes are rounded to three significant figures.

The physics shared with the diagnosis (play, Dahl hysteresis, channel delay, Coulomb friction,
gravity) is in :mod:`limbstiff.unmodelled`. Two effects are deliberately simulated in another
form than the diagnosis fits them: the reflex reads the true delayed velocity (analytic for a
position drive, the integrated history for a torque drive) where the diagnosis can only
interpolate the filtered one, and sensor drift is *drawn* here (a random walk, :func:`drift`)
where the diagnosis *estimates* it (a spline with free coefficients).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from ..unmodelled import coulomb, dahl_along, dahl_rate, delay_signal, gravity, play
from .plants import DynamicsTerm

#: Scales of the ``elbow`` scenario at its defaults (seed 0): the reference for
#: ``SimulatedEffect.defaults``.
REFERENCE_SCALES: Mapping[str, float] = {
    "torque": 0.1729, "velocity": 0.1773, "quartic_velocity": 0.2367, "angle": 0.01286,
    "stiffness": 6.0}


@dataclass(frozen=True)
class Measurement:
    """A change of the recorded channels: ``apply(time, angle, torques, rng)``.

    ``torques`` maps channel names (``torque``, ``elastic_torque``) to arrays; ``apply``
    returns the new ``(angle, torques)``.
    """

    apply: Callable


@dataclass(frozen=True)
class SimulatedEffect:
    """One unmodelled effect.

    Attributes
    ----------
    name : str
    description : str
    kind : {"dynamics", "measurement"}
    defaults : Mapping[str, float]
        Default parameters for the human elbow (``REFERENCE_SCALES``).
    sizes : callable (scales) -> dict
        Default parameters for a scenario with the given scales.
    build : callable (params) -> DynamicsTerm or Measurement
    scaled : bool
        Whether the defaults depend on the scenario's scales (if not, no nominal run is
        needed to size them).
    """

    name: str
    description: str
    kind: str
    sizes: Callable = field(repr=False)
    build: Callable = field(repr=False)
    scaled: bool = True
    defaults: Mapping[str, float] = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "defaults", self.defaults_for(REFERENCE_SCALES))

    def defaults_for(self, scales: Mapping[str, float]) -> dict[str, float]:
        """Default parameters for a scenario with these scales."""
        return {key: _round3(value) for key, value in self.sizes(scales).items()}


def _round3(x: float) -> float:
    return float(f"{x:.3g}")


def _positive(params: Mapping[str, float], *keys: str) -> None:
    for key in keys:
        if not params[key] > 0:
            raise ValueError(f"effect parameter '{key}' must be positive, got {params[key]}")


# --- dynamics -------------------------------------------------------------------------------

def _coulomb(p):
    _positive(p, "smoothing_velocity")
    fc, ve = p["friction_torque"], p["smoothing_velocity"]
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: fc * coulomb(v, ve, lib),
                        max_damping=abs(fc) / ve)


def _quadratic(p):
    c = p["coefficient"]
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: c * v * abs(v))


def _hysteresis(p):
    _positive(p, "characteristic_angle")
    f, yc = p["amplitude"], p["characteristic_angle"]
    return DynamicsTerm(
        torque=lambda y, v, z, vd, lib: z,
        state_rate=lambda y, v, z: dahl_rate(v, z, f, yc),
        state_along=lambda angle: dahl_along(angle, f, yc),
        max_stiffness=abs(f) / yc)


def _reflex(p):
    _positive(p, "delay")
    g, d, s = p["gain"], p["delay"], p["direction"]
    if s not in (1.0, -1.0):
        raise ValueError(f"effect parameter 'direction' must be 1 or -1, got {s}")
    # s·g·[s·ẏ(t − d)]₊ written without max() so that it works on floats and arrays.
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: 0.5 * g * (vd + s * abs(vd)), delay=d)


def _gravity(p):
    mgl, off = p["mgl"], p["angle_offset"]
    bias = mgl * math.sin(off)
    return DynamicsTerm(torque=lambda y, v, z, vd, lib: bias + mgl * gravity(y, off, lib),
                        max_stiffness=abs(mgl))


def _scale_error(key):
    def build(p):
        if not p["fraction"] > -1:
            raise ValueError(f"effect parameter 'fraction' must be > -1, got {p['fraction']}")
        return DynamicsTerm(**{key: 1.0 + p["fraction"]})
    return build


# --- measurement ----------------------------------------------------------------------------

def _backlash(p):
    _positive(p, "width")
    w = p["width"]
    return Measurement(lambda t, angle, torques, rng: (play(angle, w), torques))


def _time_delay(p):
    d = p["delay"]
    return Measurement(lambda t, angle, torques, rng: (
        angle, {k: delay_signal(t, x, d) for k, x in torques.items()}))


def drift(t: np.ndarray, rng: np.random.Generator, slope: float, random_walk: float,
          knot_interval: float) -> np.ndarray:
    """Sensor drift: slope·t plus a random walk, smooth between knots.

    The random walk (intensity ``random_walk``, unit/√s) is drawn at knots ``knot_interval``
    s apart and joined by a cubic spline, so it has no content above ~1/(2·knot_interval) Hz.
    A draw, not a model to fit: the diagnosis fits drift as a B-spline with free coefficients
    (``limbstiff.effects.candidates``), which contains this one.

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


def _sensor_drift(p):
    _positive(p, "knot_interval")
    return Measurement(lambda t, angle, torques, rng: (angle, {
        k: x + drift(t, rng, p["slope"], p["random_walk"], p["knot_interval"])
        for k, x in torques.items()}))


def _effect(name, kind, sizes, build, doc, scaled=True):
    return name, SimulatedEffect(name=name, description=" ".join(doc.split()), kind=kind,
                        sizes=sizes, build=build, scaled=scaled)


SIMULATED_EFFECTS: dict[str, SimulatedEffect] = dict([
    _effect("coulomb_friction", "dynamics",
            lambda s: {"friction_torque": 0.1 * s["torque"],
                       "smoothing_velocity": 0.05 * s["velocity"]},
            _coulomb, """Coulomb friction F_c·tanh(ẏ/v_ε) opposing motion (bearings, cable
            guides, an apparatus's seals). F_c = 10 % of the RMS torque (≈ 5–10 % of the
            torque amplitude); v_ε = 5 % of the RMS velocity, so it acts like a sign
            function except very near reversals."""),
    _effect("quadratic_damping", "dynamics",
            lambda s: {"coefficient": 0.15 * s["torque"] / s["quartic_velocity"] ** 2},
            _quadratic, """Quadratic (turbulent/viscoelastic) damping c·ẏ|ẏ|, N·m·s²/rad². c is
            set so that its RMS is 15 % of the RMS torque."""),
    _effect("hysteresis", "dynamics",
            lambda s: {"amplitude": 0.1 * s["torque"], "characteristic_angle": 0.2 * s["angle"]},
            _hysteresis, """Dahl hysteresis: internal torque z with dz/dt = (F·ẏ − |ẏ|·z)/y_c,
            which saturates at ±F within an angle y_c after each reversal (soft-tissue and
            short-range stiffness friction). F = 10 % of the RMS torque, y_c = 20 % of the RMS
            angle: a loop that is clearly open but thin."""),
    _effect("backlash", "measurement",
            lambda s: {"width": 0.2 * s["angle"]},
            _backlash, """Play of total width in the angle measurement (an encoder behind a
            gear or a loose cuff): the recorded angle stays put until the true angle has
            crossed a dead band of ±width/2. Width = 20 % of the RMS angle (0.15° for the
            elbow)."""),
    _effect("time_delay", "measurement",
            lambda s: {"delay": 0.01},
            _time_delay, """The recorded torque lags the angle by `delay` s (unmatched
            anti-aliasing filters, a slow torque amplifier, a bus). 10 ms: larger than a
            sample but small against the 40 ms of a reflex.""", scaled=False),
    _effect("reflex", "dynamics",
            lambda s: {"gain": 0.3 * s["torque"] / s["velocity"], "delay": 0.04,
                       "direction": 1.0},
            _reflex, """Stretch reflex: torque direction·g·[direction·ẏ(t − delay)]₊ that
            resists stretch in one direction only (direction +1 stretches the muscle with
            positive velocity), after the loop delay (default 40 ms, physiological range
            20–80 ms). g = 0.3·RMS torque/RMS velocity, so the half-wave-rectified reflex
            torque is ~15–25 % of the torque, as in the ankle recordings."""),
    _effect("gravity", "dynamics",
            lambda s: {"mgl": 0.2 * s["stiffness"], "angle_offset": 0.0},
            _gravity, """Gravity on an unbalanced segment: −mgl·(sin(y + angle_offset) −
            sin(angle_offset)), the sign of the paper's link (destabilising about the upright
            position; the static weight at the operating point is taken as compensated).
            mgl = 20 % of the smallest stiffness, so the joint stays stable but looks 20 %
            softer."""),
    _effect("sensor_drift", "measurement",
            lambda s: {"slope": 0.005 * s["torque"], "random_walk": 0.02 * s["torque"],
                       "knot_interval": 1.0},
            _sensor_drift, """Torque sensor drift (thermal strain-gauge drift): slope·t plus a
            low-frequency random walk (spline through knots `knot_interval` s apart). Slope
            0.5 %·RMS torque per second and walk intensity 2 %·RMS torque/√s: over 30 s about
            15 % and 10 % of the RMS torque."""),
    _effect("inertia_error", "dynamics",
            lambda s: {"fraction": 0.2},
            _scale_error("inertia_scale"), """The true inertia is the nominal one × (1 +
            fraction) (an unaccounted handle, brace or footplate); the scenario parameters
            and `nominal_inertia` keep the nominal value a user would assume, `true_inertia`
            the real one. No effect on massless scenarios.""", scaled=False),
    _effect("damping_error", "dynamics",
            lambda s: {"fraction": 0.3},
            _scale_error("damping_scale"), """The true damping is the nominal one × (1 +
            fraction); `nominal_damping` keeps the value a user would assume, `true_damping`
            the real one. Damping is the least known parameter of a limb, hence 30 %.""",
            scaled=False),
])
