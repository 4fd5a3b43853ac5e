"""The library of candidate unmodelled effects: one physically named, parametric term each.

Each entry of :data:`CANDIDATES` is one object of a kind from :mod:`.kinds` that adds to the
nominal model f = m·ÿ + b·ẏ + s(y, t) either

* a **torque** e = Σ aᵢ·φᵢ(y, ẏ, ÿ; shape) on the joint (friction, reflex…) — linear in
  its amplitudes aᵢ once its shape parameters are fixed, so the amplitudes are fitted by least
  squares and the shape profiled over a small grid bounded by physics;
* a **correction of a recorded channel** (the torque shifted in time, the angle seen through a
  gear's play) — profiled over a grid of its one parameter; or
* an **error of the nominal inertia or damping**.

A torque φ is computed from the filtered signals and passed through the same low-pass as the
recorded torque. Grids come from the trial's own scales (:class:`~.kinds.Scales`), with the
reason stated beside each. A new effect is one new entry of :data:`CANDIDATES`. The physics shared
with the simulator (play, Dahl hysteresis, channel delay, Coulomb friction) is in
:mod:`limbstiff.unmodelled`. Not in the library: gravity and sensor drift. A torque that depends on
the angle alone (gravity on an unbalanced segment) is a generalized stiffness, which the model
holds (its static nonlinear spring and its time-varying stiffness), and a slow drift of the
torque offset is a walk of the elastic torque (Q_s). Pure numpy/scipy: no I/O.

Sign convention (as the simulator): the effect torque e is on the left-hand side,
f = m·ÿ + b·ẏ + s + e, so a positive friction torque opposes motion.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import signal as sps

from ..unmodelled import coulomb, dahl, delay_signal, play
from .channels import Channels
from .kinds import ChannelCorrection, ModelEffect, MechanicsOffset, TorqueEffect


# --- shapes -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Movements:
    """Movement events of a trial's recorded angle, read through a play just wider than its noise.

    Parameters
    ----------
    play : ndarray, shape (n,), rad
        The recorded angle through the play.
    moves : ndarray of int, shape (k,)
        Samples where that moves.
    signs : ndarray, shape (k,)
        The direction of each move (±1).
    """

    play: np.ndarray
    moves: np.ndarray
    signs: np.ndarray

    @classmethod
    def of(cls, ch: Channels) -> "Movements":
        """The movements of ``ch.raw_angle`` through a play of the encoder step, or six angle-noise
        standard deviations, whichever is wider."""
        raw = ch.raw_angle
        eps = max(1.01 * ch.quantisation_step, 6.0 * ch.angle_noise, 1e-12 * max(np.ptp(raw), 1e-300))
        p = play(raw, eps)
        dp = np.diff(p, prepend=p[0])
        moves = np.flatnonzero(dp != 0)
        return cls(p, moves, np.sign(dp[moves]))


def _movements(ch: Channels) -> Movements:
    """:meth:`Movements.of` ``ch``, computed once per :class:`Channels` and kept on it (as
    :meth:`Channels.linear_part` keeps its basis): a backlash is evaluated at every width of its
    grid on the same channels, and the play is a loop over the samples. The channels are frozen,
    so what determines the movements (raw angle, encoder step, noise) cannot change under them."""
    known = ch.__dict__.get("_movements")
    if known is None:
        known = Movements.of(ch)
        object.__setattr__(ch, "_movements", known)
    return known


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
    mv = _movements(ch)
    p, moves, s = mv.play, mv.moves, mv.signs
    if moves.size == 0:
        return np.zeros(n)
    d = s[np.maximum(np.searchsorted(moves, np.arange(n), side="right") - 1, 0)].astype(float)
    j = np.flatnonzero(s[1:] != s[:-1])               # reversals: last move one way, first move back
    start, end = moves[j], moves[j + 1]
    jj = np.minimum(j + 4, len(moves) - 1)
    speed = np.abs(p[moves[jj]] - p[end - 1]) / ((moves[jj] - end + 1) / ch.fs)
    span = np.minimum(end - start - 1, np.round(2.0 * width / np.maximum(speed, 1e-12) * ch.fs)).astype(int)
    keep = span > 0
    span, end, sign = span[keep], end[keep], s[j[keep]]
    # the dwells are disjoint, so their swings are written at once
    offset = np.arange(span.sum()) - np.repeat(np.cumsum(span) - span, span)
    u = (offset + 1) / np.repeat(span, span)
    d[np.repeat(end - span, span) + offset] = np.repeat(sign, span) * (1.0 - 2.0 * u ** 2)
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

def _geom(lo: float, hi: float, k: int) -> list[float]:
    lo = max(lo, 1e-12)
    return [float(v) for v in (np.geomspace(lo, hi, k) if hi > lo * 1.01 else [hi])]


# --- the library --------------------------------------------------------------------------

def _hysteresis_low(s) -> float:
    """The narrowest Dahl loop resolved, rad: twice the angle resolution, or 2 % of the RMS angle."""
    return max(2 * s.angle_resolution, 0.02 * s.angle)


def _friction_grid(s) -> list[dict]:
    """Coulomb friction's shapes: smoothing velocities, then presliding angles up to the
    narrowest hysteresis loop (where the two effects are one torque)."""
    low = _hysteresis_low(s)
    return ([{"smoothing_velocity": v} for v in _geom(max(s.velocity_noise, 0.003 * s.velocity), 0.3 * s.velocity, 6)]
            + [{"presliding_angle": v} for v in _geom(max(2 * s.angle_resolution, 0.1 * low), low, 3)])


def _friction(ch, sh):
    """tanh(ẏ/v_ε), or the Dahl friction state over the presliding angle (unit amplitude), shape (n,)."""
    if "presliding_angle" in sh:
        return dahl(ch.angle, sh["presliding_angle"])
    return coulomb(ch.velocity, sh["smoothing_velocity"])


def _quadratic(ch, sh):
    """ẏ|ẏ| of the filtered velocity, (rad/s)², shape (n,)."""
    v = ch.velocity
    return v * np.abs(v)


def _backlash(ch, x, sh):
    """The joint's angle behind a play of ``sh['width']``, from the recorded angle ``x`` (n,), rad."""
    return x + 0.5 * sh["width"] * backlash_direction(ch, sh["width"])


def _reflex(ch, sh):
    """direction·[direction·ẏ(t − δ)]₊ through the activation dynamics, rad/s, shape (n,)."""
    s = sh["direction"]
    return _activation(s * np.maximum(s * _delayed_velocity(ch, sh["delay"]), 0.0), ch.fs, sh["activation_hz"])


def _delayed_velocity(ch, delay: float) -> np.ndarray:
    """ẏ(t − δ), kept on ``ch`` for the last δ asked: the reflex grid runs delay by delay (ten
    shapes each), and one array, not thirteen, stays in memory."""
    kept = ch.__dict__.get("_delayed_velocity")
    if kept is None or kept[0] != delay:
        kept = (delay, delay_signal(ch.time, ch.velocity, delay, before=0.0))
        object.__setattr__(ch, "_delayed_velocity", kept)
    return kept[1]


REFLEX_DELAYS_S = tuple(np.round(np.arange(0.020, 0.0801, 0.005), 3))
#: Activation corners of the reflex torque, Hz: None, then 1/(2π·T_c) for contraction times T_c of
#: 30, 60, 90 and 120 ms.
ACTIVATION_HZ = (None,) + tuple(float(np.round(1.0 / (2 * np.pi * tc), 3)) for tc in (0.03, 0.06, 0.09, 0.12))
TIME_DELAYS_S = tuple(np.round(np.arange(-0.050, 0.0501, 0.001), 3))

CANDIDATES: dict[str, ModelEffect] = {e.name: e for e in (
    TorqueEffect(
        name="coulomb_friction", description="Coulomb friction F_c opposing motion (bearings, seals, cable "
        "guides): F_c·tanh(ẏ/v_ε), or with presliding (LuGre's bristles, Dahl's friction model) F_c·z, "
        "dz/dy = (sgn(ẏ) − z)/y_p, the friction building up over the presliding angle y_p after each "
        "reversal.", amplitudes=("friction_torque",),
        units={"friction_torque": "N·m", "smoothing_velocity": "rad/s", "presliding_angle": "rad"},
        grid=_friction_grid,
        grid_reason="v_ε from the velocity noise level (below it the sign of ẏ is unknown) to 0.3×RMS "
        "velocity (above it tanh is nearly linear over the motion: a viscous term); presliding angles "
        "from a tenth of the narrowest hysteresis loop to it (a wider loop is hysteresis)",
        torque=_friction),
    TorqueEffect(
        name="quadratic_damping", description="Quadratic (turbulent, viscoelastic) damping c·ẏ|ẏ|.",
        amplitudes=("coefficient",), units={"coefficient": "N·m·s²/rad²"}, grid=lambda s: [{}], grid_reason="no shape parameter",
        torque=_quadratic),
    TorqueEffect(
        name="hysteresis", description="Dahl hysteresis z with dz/dy = (sgn(ẏ)·F − z)/y_c: a friction "
        "torque that builds up over the angle y_c after each reversal (soft tissue, short-range "
        "stiffness).", amplitudes=("amplitude",), units={"amplitude": "N·m", "characteristic_angle": "rad"},
        grid=lambda s: [{"characteristic_angle": v} for v in _geom(_hysteresis_low(s), s.angle, 6)],
        grid_reason="y_c from twice the angle resolution (a narrower loop is Coulomb friction) to the RMS "
        "angle (a loop that never saturates acts as a spring)",
        torque=lambda ch, sh: dahl(ch.angle, sh["characteristic_angle"]), lower_limit="coulomb_friction"),
    ChannelCorrection(
        name="backlash", description="Play of total width w between the joint and the angle sensor (a "
        "gear, a loose cuff): the recorded angle stays put while the joint crosses the dead band.",
        grid=lambda s: [{"width": v} for v in _geom(max(2 * s.angle_resolution, 0.01 * s.angle),
                                                    0.5 * s.angle, 20)],
        grid_reason="w from twice the angle resolution or 1 % of the RMS angle (a narrower play is "
        "invisible) to half the RMS angle (a wider one would hold the recorded angle still most of the "
        "time), 20 values: the fit is sharply peaked in w", channel="angle", correct=_backlash,
        units={"width": "rad"}),
    ChannelCorrection(
        name="time_delay", description="The torque channel lags the angle channel by d (unmatched "
        "anti-aliasing filters, amplifiers, a bus); d < 0: the angle lags.",
        grid=lambda s: [{"delay": float(d)} for d in TIME_DELAYS_S],
        grid_reason="±50 ms in 1 ms steps: longer lags are a broken set-up, and beyond 20 ms a lag "
        "overlaps the reflex loop", channel="torque", units={"delay": "s"},
        # f_recorded(t) = f(t − d): the torque the joint saw at t is the one recorded at t + d
        correct=lambda ch, x, sh: delay_signal(ch.time, x, -sh["delay"])),
    TorqueEffect(
        name="reflex", description="Stretch reflex: delayed, half-wave rectified velocity feedback "
        "direction·g·[direction·ẏ(t − δ)]₊ resisting stretch in one direction, optionally through "
        "muscle activation dynamics (critically damped second-order low-pass).", amplitudes=("gain",),
        units={"gain": "N·m·s/rad", "delay": "s", "direction": "1 (+1: stretch towards positive angles)",
               "activation_hz": "Hz (none: no activation dynamics)"},
        grid=lambda s: [{"delay": float(d), "direction": sgn, "activation_hz": fa}
                        for d in REFLEX_DELAYS_S for sgn in (1.0, -1.0) for fa in ACTIVATION_HZ],
        grid_reason="loop delays 20–80 ms (spinal stretch reflexes of human limbs) in 5 ms steps; both "
        "stretch directions; activation dynamics none (torque follows the rectified velocity at once) "
        "or a critically damped low-pass whose impulse response peaks at the twitch contraction time "
        "of human muscles, 30, 60, 90 or 120 ms (fast muscles to soleus): corners 1/(2π·T_c)",
        torque=_reflex),
    MechanicsOffset(
        name="inertia_error", description="The true inertia differs from the nominal one by Δm (a "
        "handle, brace or footplate not accounted for).", amplitudes=("delta_inertia",),
        units={"delta_inertia": "kg·m²", "fraction": "1 (of the nominal inertia)"},
        grid=lambda s: [{}], grid_reason="no shape parameter", parameter="inertia",
        signal="acceleration"),
    MechanicsOffset(
        name="damping_error", description="The true damping differs from the nominal one by Δb.",
        amplitudes=("delta_damping",),
        units={"delta_damping": "N·m·s/rad", "fraction": "1 (of the nominal damping)"}, grid=lambda s: [{}], grid_reason="no shape parameter",
        parameter="damping", signal="velocity"),
)}

