"""The library of candidate unmodelled effects: one physically named, parametric term each.

Each :class:`Effect` adds to the nominal model f = m·ÿ + b·ẏ + s(y, t) either

* a **torque** e = Σ aᵢ·φᵢ(y, ẏ, ÿ; shape) on the joint (friction, reflex, gravity…) — linear in
  its amplitudes aᵢ once its shape parameters are fixed, so the amplitudes are fitted by least
  squares and the shape profiled over a small grid bounded by physics; or
* a **correction of a recorded channel** (the torque shifted in time, the angle seen through a
  gear's play) — profiled over a grid of its one parameter.

A torque φ is computed from the filtered signals and passed through the same low-pass as the
recorded torque. Grids come from the trial's own scales (:class:`Scales`), with the reason
stated beside each. ``correction`` gives what the stiffness re-estimate needs: the recorded
channels with the effect removed. Pure numpy/scipy: no I/O.

Sign convention (as the simulator): the effect torque e is on the left-hand side,
f = m·ÿ + b·ẏ + s + e, so a positive friction torque opposes motion.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Mapping

import numpy as np
from scipy import signal as sps

from ..estimate.observer import linear_recursion
from .channels import Channels


@dataclass(frozen=True)
class Scales:
    """Sizes that set the grids, pooled (medians) over the trials diagnosed together.

    Parameters
    ----------
    velocity : float, rad/s
        RMS of ẏ.
    angle : float, rad
        Standard deviation of y.
    velocity_noise : float, rad/s
    angle_resolution : float, rad
    motion_hz : float, Hz
    """

    velocity: float
    angle: float
    velocity_noise: float
    angle_resolution: float
    motion_hz: float

    @classmethod
    def of(cls, channels) -> "Scales":
        def med(f):
            return float(np.median([f(c) for c in channels]))
        return cls(velocity=med(lambda c: np.sqrt(np.mean(c.velocity ** 2))), angle=med(lambda c: np.std(c.angle)),
                   velocity_noise=med(lambda c: c.velocity_noise), angle_resolution=med(lambda c: c.angle_resolution),
                   motion_hz=med(lambda c: c.motion_hz))


@dataclass(frozen=True)
class Term:
    """One effect at one shape, evaluated on one trial (full rate).

    Parameters
    ----------
    regressors : ndarray, shape (p, n), or None
        Torques per unit amplitude, low-passed like the torque (N·m per amplitude unit).
    angle : ndarray, shape (3, n), or None
        Corrected filtered y, ẏ, ÿ.
    torque : ndarray, shape (n,), or None
        Corrected filtered torque.
    """

    regressors: np.ndarray | None = None
    angle: np.ndarray | None = None
    torque: np.ndarray | None = None


@dataclass(frozen=True)
class Correction:
    """The recorded channels with an effect removed, for the stiffness re-estimate.

    ``angle``/``torque``: corrected raw channels (n,) or None; ``inertia``/``damping``: the
    corrected m and b, or None when unchanged.
    """

    angle: np.ndarray | None = None
    torque: np.ndarray | None = None
    inertia: float | None = None
    damping: float | None = None


@dataclass(frozen=True)
class Effect:
    """A candidate unmodelled effect.

    Attributes
    ----------
    name : str
    description : str
        The physics and the parametrisation, one paragraph.
    kind : {"dynamics", "measurement", "mechanics"}
    amplitudes : tuple of str
        Names (with SI units) of the amplitudes fitted by least squares, one per regressor.
    grid : callable (Scales) -> list of dict
        Shape parameters to profile over.
    grid_reason : str
        Why the grid spans what it spans.
    evaluate : callable (Channels, dict) -> Term
    local : bool
        The term has no parameter that carries over to other data (sensor drift): it is judged
        by predicting held-out slices within a recording (``crossval``).
    """

    name: str
    description: str
    kind: str
    amplitudes: tuple
    grid: Callable
    grid_reason: str
    evaluate: Callable
    local: bool = False

    def params(self, shape: Mapping, coef, ch: Channels | None = None) -> dict:
        """Physical parameters: the shape and the named amplitudes (plus relative errors)."""
        out = {k: (None if v is None else float(v)) for k, v in shape.items()}
        coef = np.atleast_1d(np.asarray(coef, float))
        if self.local:
            return out
        for name, value in zip(self.amplitudes, coef):
            out[name] = float(value)
        if ch is not None and self.name in ("inertia_error", "damping_error"):
            nominal = ch.inertia if self.name == "inertia_error" else ch.damping
            out["fraction"] = float(coef[0] / nominal) if nominal > 0 else None
        return out

    def correction(self, ch: Channels, shape: Mapping, coef) -> Correction:
        """Remove the fitted effect from the recorded channels (see :func:`remove`)."""
        return remove(ch, [(self, shape, coef)])


# --- shapes -------------------------------------------------------------------------------

def dahl(angle: np.ndarray, characteristic_angle: float) -> np.ndarray:
    """Dahl hysteresis state of unit amplitude along an angle path (exact for monotone steps).

    dz/dy = (sgn(ẏ) − z)/y_c: after each reversal the torque relaxes exponentially towards ±1
    over the angle y_c. Shape (n,).
    """
    dy = np.diff(angle, prepend=angle[0])
    a = np.exp(-np.abs(dy) / characteristic_angle)
    return linear_recursion(a, (1.0 - a) * np.sign(dy))


def play(x: np.ndarray, width: float) -> np.ndarray:
    """Play operator of total ``width``: the output follows the input only once it has crossed
    a dead band ±width/2 around it (starts at x[0])."""
    half = 0.5 * width
    out, o = np.empty(len(x)), float(x[0])
    for k, xi in enumerate(np.asarray(x, dtype=float).tolist()):
        if xi - o > half:
            o = xi - half
        elif o - xi > half:
            o = xi + half
        out[k] = o
    return out


_MOVES: dict = {}


def _movements(ch: Channels):
    """Movement events of the recorded angle: play output p, event indices, their signs (cached)."""
    import weakref
    raw = ch.raw_angle
    hit = _MOVES.get(id(raw))
    if hit is not None and hit[0]() is raw:
        return hit[1]
    eps = max(1.01 * ch.quantisation_step, 6.0 * ch.angle_noise, 1e-12 * max(np.ptp(raw), 1e-300))
    p = play(raw, eps)
    dp = np.diff(p, prepend=p[0])
    moves = np.flatnonzero(dp != 0)
    out = (p, moves, np.sign(dp[moves]))
    for key in [k for k, v in _MOVES.items() if v[0]() is None]:
        del _MOVES[key]
    _MOVES[id(raw)] = (weakref.ref(raw), out)
    return out


def backlash_direction(ch: Channels, width: float) -> np.ndarray:
    """D(t) ∈ [−1, 1] with true angle ≈ recorded angle + (width/2)·D, behind a play of ``width``.

    While the recorded angle moves, the joint pushes the play to one side: D = ±1, the direction
    of motion. When the recorded angle stops and then moves back, the joint crossed the play in
    between: D swings from one side to the other over the last part of the dwell, during the time
    2·width/v the joint needs to cross it starting from rest at the speed v it has once the recorded
    angle moves again (uniform acceleration). Movements are read from the raw angle through a play
    just wider than the encoder step, or six noise standard deviations, so that noise does not count.
    """
    n = ch.n
    p, moves, s = _movements(ch)
    if moves.size == 0:
        return np.zeros(n)
    d = s[np.maximum(np.searchsorted(moves, np.arange(n), side="right") - 1, 0)].astype(float)
    for j in np.flatnonzero(s[1:] != s[:-1]):
        start, end = moves[j], moves[j + 1]          # last move one way, first move back
        jj = min(j + 4, len(moves) - 1)
        dt = (moves[jj] - end + 1) / ch.fs
        speed = abs(p[moves[jj]] - p[end - 1]) / dt
        span = min(end - start - 1, int(round(2.0 * width / max(speed, 1e-12) * ch.fs)))
        if span > 0:
            u = np.arange(1, span + 1) / span
            d[end - span:end] = s[j] * (1.0 - 2.0 * u ** 2)
    return d


def _activation(x: np.ndarray, fs: float, corner_hz: float | None) -> np.ndarray:
    """Critically damped second-order low-pass 1/(τs + 1)², causal (muscle activation dynamics)."""
    if corner_hz is None:
        return x
    return sps.lfilter(*_activation_filter(corner_hz, fs), x)


@lru_cache(maxsize=64)
def _activation_filter(corner_hz: float, fs: float):
    tau = 1.0 / (2 * np.pi * corner_hz)
    return sps.bilinear([1.0], [tau * tau, 2 * tau, 1.0], fs=fs)


def filtered_torque(ch: Channels, x: np.ndarray) -> np.ndarray:
    """A torque with sharp features computed from the filtered signals, made comparable with the
    filtered record.

    The recorded torque went through the low-pass once, so an effect torque with content above
    the band (a kink at reversals: friction, rectification, hysteresis) must too — but only its
    part that is not a linear function of the filtered y, ẏ, ÿ: those carry the angle's in-band
    noise exactly as the nominal model's own terms do, and filtering them a second time would
    leave (H² − H)·noise, which correlates with the m·ÿ noise of the residual. So
    φ = L + H(φ − L), L its least-squares fit on 1, y, ẏ, ÿ. Smooth torques (gravity, inertia,
    damping) are not filtered again at all: measured on the clean simulated elbow (8000-count
    encoder), a −mgl·sin y term filtered whole "explained" 21 % of the gap with mgl = 270 N·m
    and split as above still 11 %, both by fitting the filtered angle noise; unfiltered, 0 %.
    """
    x = np.asarray(x, float)
    if ch.chain.kind == "paper":
        # a causal chain lags: the filtered signals already carry the prefilter's lag, and a second
        # pass would lag the torque twice (measured on the elbow with a reflex at 66.7 Hz)
        return x
    linear = ch.linear_part(x)
    return linear + ch.lowpass(x - linear)


def _geom(lo: float, hi: float, k: int) -> list[float]:
    lo = max(lo, 1e-12)
    return [float(v) for v in (np.geomspace(lo, hi, k) if hi > lo * 1.01 else [hi])]


# --- the library --------------------------------------------------------------------------

def _coulomb(ch, sh):
    return Term(regressors=filtered_torque(ch, np.tanh(ch.velocity / sh["smoothing_velocity"]))[None])


def _quadratic(ch, sh):
    v = ch.velocity
    return Term(regressors=filtered_torque(ch, v * np.abs(v))[None])


def _hysteresis(ch, sh):
    return Term(regressors=filtered_torque(ch, dahl(ch.angle, sh["characteristic_angle"]))[None])


def _backlash(ch, sh):
    x = ch.raw_angle + 0.5 * sh["width"] * backlash_direction(ch, sh["width"])
    return Term(angle=ch.differentiate(x, 2))


def _time_delay(ch, sh):
    # f_recorded(t) = f(t − d): the torque the joint saw at t is the one recorded at t + d
    return Term(torque=np.interp(ch.time + sh["delay"], ch.time, ch.torque))


def _reflex(ch, sh):
    s = sh["direction"]
    vd = np.interp(ch.time - sh["delay"], ch.time, ch.velocity, left=0.0)
    drive = s * np.maximum(s * vd, 0.0)
    return Term(regressors=filtered_torque(ch, _activation(drive, ch.fs, sh["activation_hz"]))[None])


def _gravity(ch, sh):
    return Term(regressors=-np.sin(ch.angle + sh["angle_offset"])[None])


def _drift(ch, sh):
    from scipy.interpolate import BSpline
    t0, t1 = float(ch.time[0]), float(ch.time[-1])
    step = sh["knot_interval"]
    inner = np.arange(t0, t1 + step, step)
    knots = np.concatenate([[inner[0]] * 3, inner, [inner[-1]] * 3])
    basis = BSpline.design_matrix(np.clip(ch.time, t0, inner[-1]), knots, 3).toarray()
    return Term(regressors=basis.T)


def _inertia(ch, sh):
    return Term(regressors=ch.acceleration[None])


def _damping(ch, sh):
    return Term(regressors=ch.velocity[None])


REFLEX_DELAYS_S = tuple(np.round(np.arange(0.020, 0.0801, 0.005), 3))
#: Activation corners of the reflex torque, Hz: None, then 1/(2π·T_c) for contraction times T_c of
#: 30, 60, 90 and 120 ms.
ACTIVATION_HZ = (None,) + tuple(float(np.round(1.0 / (2 * np.pi * tc), 3)) for tc in (0.03, 0.06, 0.09, 0.12))
TIME_DELAYS_S = tuple(np.round(np.arange(-0.050, 0.0501, 0.001), 3))

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("coulomb_friction", "Coulomb friction F_c·tanh(ẏ/v_ε) opposing motion (bearings, seals, "
           "cable guides).", "dynamics", ("friction_torque",),
           lambda s: [{"smoothing_velocity": v} for v in _geom(max(s.velocity_noise, 0.003 * s.velocity),
                                                               0.3 * s.velocity, 6)],
           "v_ε from the velocity noise level (below it the sign of ẏ is unknown) to 0.3×RMS velocity "
           "(above it tanh is nearly linear over the motion: a viscous term)", _coulomb),
    Effect("quadratic_damping", "Quadratic (turbulent, viscoelastic) damping c·ẏ|ẏ|.", "dynamics",
           ("coefficient",), lambda s: [{}], "no shape parameter", _quadratic),
    Effect("hysteresis", "Dahl hysteresis z with dz/dy = (sgn(ẏ)·F − z)/y_c: a friction torque that "
           "builds up over the angle y_c after each reversal (soft tissue, short-range stiffness).",
           "dynamics", ("amplitude",),
           lambda s: [{"characteristic_angle": v} for v in _geom(max(2 * s.angle_resolution, 0.02 * s.angle),
                                                                 s.angle, 6)],
           "y_c from twice the angle resolution (a narrower loop is Coulomb friction) to the RMS angle "
           "(a loop that never saturates acts as a spring)", _hysteresis),
    Effect("backlash", "Play of total width w between the joint and the angle sensor (a gear, a loose "
           "cuff): the recorded angle stays put while the joint crosses the dead band.", "measurement",
           (), lambda s: [{"width": v} for v in _geom(max(2 * s.angle_resolution, 0.01 * s.angle),
                                                     0.5 * s.angle, 20)],
           "w from twice the angle resolution or 1 % of the RMS angle (a narrower play is invisible) "
           "to half the RMS angle (a wider one would hold the recorded angle still most of the "
           "time), 20 values: the fit is sharply peaked in w", _backlash),
    Effect("time_delay", "The torque channel lags the angle channel by d (unmatched anti-aliasing "
           "filters, amplifiers, a bus); d < 0: the angle lags.", "measurement", (),
           lambda s: [{"delay": float(d)} for d in TIME_DELAYS_S],
           "±50 ms in 1 ms steps: longer lags are a broken set-up, and beyond 20 ms a lag overlaps the "
           "reflex loop", _time_delay),
    Effect("reflex", "Stretch reflex: delayed, half-wave rectified velocity feedback "
           "direction·g·[direction·ẏ(t − δ)]₊ resisting stretch in one direction, optionally through "
           "muscle activation dynamics (critically damped second-order low-pass).", "dynamics", ("gain",),
           lambda s: [{"delay": float(d), "direction": sgn, "activation_hz": fa}
                      for d in REFLEX_DELAYS_S for sgn in (1.0, -1.0) for fa in ACTIVATION_HZ],
           "loop delays 20–80 ms (spinal stretch reflexes of human limbs) in 5 ms steps; both stretch "
           "directions; activation dynamics none (torque follows the rectified velocity at once) or a "
           "critically damped low-pass whose impulse response peaks at the twitch contraction time of "
           "human muscles, 30, 60, 90 or 120 ms (fast muscles to soleus): corners 1/(2π·T_c)",
           _reflex),
    Effect("gravity", "Gravity on an unbalanced segment −mgl·sin(y + θ₀) (θ₀: angle from the "
           "upright at y = 0).", "dynamics", ("mgl",),
           lambda s: [{"angle_offset": float(a)} for a in np.linspace(-np.pi / 2, np.pi / 2, 7)],
           "θ₀ over ±90° in 30° steps (the sign of mgl is free, so this covers every orientation); its "
           "part linear in y is a stiffness and is absorbed by the elastic term", _gravity),
    Effect("sensor_drift", "Slow drift of the torque sensor's offset (thermal strain-gauge drift), a "
           "cubic spline in time; faster than the elastic windows, slower than the motion.", "measurement",
           (), lambda s: [{"knot_interval": float(2.0 / s.motion_hz)}],
           "knots every 2 motion periods: between the motion (faster torque is not drift) and the "
           "4-period elastic windows (a slower drift is a change of the elastic equilibrium, which "
           "the model already allows); one value, so nothing is selected on held-out data", _drift,
           local=True),
    Effect("inertia_error", "The true inertia differs from the nominal one by Δm (a handle, brace or "
           "footplate not accounted for).", "mechanics", ("delta_inertia",), lambda s: [{}],
           "no shape parameter", _inertia),
    Effect("damping_error", "The true damping differs from the nominal one by Δb.", "mechanics",
           ("delta_damping",), lambda s: [{}], "no shape parameter", _damping),
)}


def remove(ch: Channels, fitted) -> Correction:
    """Remove several fitted effects, in the order given, from the recorded channels.

    Parameters
    ----------
    ch : Channels
    fitted : sequence of (Effect, dict, ndarray)
        Effect, shape and amplitudes; each torque is computed on the channels corrected by the
        effects before it (as they were fitted).

    Returns
    -------
    Correction
        Raw angle and torque with every effect removed (None when unchanged), m and b.
    """
    angle, torque = ch.raw_angle, ch.raw_torque
    inertia, damping = ch.inertia, ch.damping
    for effect, shape, coef in fitted:
        coef = np.atleast_1d(np.asarray(coef, float))
        if effect.name == "inertia_error":
            inertia += float(coef[0])
        elif effect.name == "damping_error":
            damping += float(coef[0])
        elif effect.name == "time_delay":
            torque = np.interp(ch.time + shape["delay"], ch.time, torque)
        elif effect.name == "backlash":
            angle = angle + 0.5 * shape["width"] * backlash_direction(ch, shape["width"])
        term = effect.evaluate(ch, shape)
        if effect.kind != "mechanics" and term.regressors is not None:
            torque = torque - coef @ term.regressors
        ch = ch.with_channels(angle=term.angle, torque=term.torque)
    return Correction(angle=None if angle is ch.raw_angle else angle,
                      torque=None if torque is ch.raw_torque else torque,
                      inertia=inertia, damping=damping)
