"""How the model holds the candidate effects: their shapes, and the grids they are profiled over.

Each effect of the registry (:data:`limbstiff.effects.registry.EFFECTS`) that the model can hold
has a model part of a kind from :mod:`.kinds`, which adds to the nominal model
f = m·ÿ + b·ẏ + s(y, t) either

* a **torque** e = Σ aᵢ·φᵢ(y, ẏ, ÿ; shape) on the joint (friction, reflex…) — linear in
  its amplitudes aᵢ once its shape parameters are fixed, so the amplitudes are fitted by least
  squares and the shape profiled over a small grid bounded by physics;
* a **correction of a recorded channel** (the torque shifted in time, the angle seen through a
  gear's play) — profiled over a grid of its one parameter; or
* an **error of the nominal inertia or damping**.

The shapes φ and the grids are here. A torque φ is computed from the filtered signals and passed
through the same low-pass as the recorded torque. Grids come from the trial's own scales
(:class:`~.kinds.Scales`), with the reason stated beside each in the registry, which also says why
gravity and sensor drift need no model part (``held_by_nominal``). Pure numpy/scipy: no I/O.

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


def activation(x: np.ndarray, fs: float, corner_hz: float | None) -> np.ndarray:
    """Critically damped second-order low-pass 1/(τs + 1)², causal (muscle activation dynamics)."""
    if corner_hz is None:
        return x
    return sps.lfilter(*_activation_filter(corner_hz, fs), x)


@lru_cache(maxsize=64)
def _activation_filter(corner_hz: float, fs: float):
    tau = 1.0 / (2 * np.pi * corner_hz)
    return sps.bilinear([1.0], [tau * tau, 2 * tau, 1.0], fs=fs)


def geom(lo: float, hi: float, k: int) -> list[float]:
    """``k`` values from ``lo`` to ``hi`` spaced evenly on a log scale (``[hi]`` when the range is
    narrower than 1 %; ``lo`` at least 10⁻¹²)."""
    lo = max(lo, 1e-12)
    return [float(v) for v in (np.geomspace(lo, hi, k) if hi > lo * 1.01 else [hi])]


# --- torques, corrections and grids ---------------------------------------------------------

def hysteresis_low(s) -> float:
    """The narrowest Dahl loop resolved, rad: twice the angle resolution, or 2 % of the RMS angle."""
    return max(2 * s.angle_resolution, 0.02 * s.angle)


def friction_grid(s) -> list[dict]:
    """Coulomb friction's shapes: smoothing velocities, then presliding angles up to the
    narrowest hysteresis loop (where the two effects are one torque)."""
    low = hysteresis_low(s)
    return ([{"smoothing_velocity": v} for v in geom(max(s.velocity_noise, 0.003 * s.velocity), 0.3 * s.velocity, 6)]
            + [{"presliding_angle": v} for v in geom(max(2 * s.angle_resolution, 0.1 * low), low, 3)])


def friction_torque(ch, sh):
    """tanh(ẏ/v_ε), or the Dahl friction state over the presliding angle (unit amplitude), shape (n,)."""
    if "presliding_angle" in sh:
        return dahl(ch.angle, sh["presliding_angle"])
    return coulomb(ch.velocity, sh["smoothing_velocity"])


def quadratic_torque(ch, sh):
    """ẏ|ẏ| of the filtered velocity, (rad/s)², shape (n,)."""
    v = ch.velocity
    return v * np.abs(v)


def backlash_angle(ch, x, sh):
    """The joint's angle behind a play of ``sh['width']``, from the recorded angle ``x`` (n,), rad."""
    return x + 0.5 * sh["width"] * backlash_direction(ch, sh["width"])


def reflex_torque(ch, sh):
    """direction·[direction·ẏ(t − δ)]₊ through the activation dynamics, rad/s, shape (n,)."""
    s = sh["direction"]
    return activation(s * np.maximum(s * _delayed_velocity(ch, sh["delay"]), 0.0), ch.fs, sh["activation_hz"])


def _delayed_velocity(ch, delay: float) -> np.ndarray:
    """ẏ(t − δ), kept on ``ch`` for the last δ asked: the reflex grid runs delay by delay (ten
    shapes each), and one array, not thirteen, stays in memory."""
    kept = ch.__dict__.get("_delayed_velocity")
    if kept is None or kept[0] != delay:
        kept = (delay, delay_signal(ch.time, ch.velocity, delay, before=0.0))
        object.__setattr__(ch, "_delayed_velocity", kept)
    return kept[1]


#: Loop delays of the reflex, s: 20–80 ms in 5 ms steps.
REFLEX_DELAYS_S = tuple(np.round(np.arange(0.020, 0.0801, 0.005), 3))
#: Activation corners of the reflex torque, Hz: None, then 1/(2π·T_c) for contraction times T_c of
#: 30, 60, 90 and 120 ms.
ACTIVATION_HZ = (None,) + tuple(float(np.round(1.0 / (2 * np.pi * tc), 3)) for tc in (0.03, 0.06, 0.09, 0.12))
#: Lags of the torque channel, s: ±50 ms in 1 ms steps.
TIME_DELAYS_S = tuple(np.round(np.arange(-0.050, 0.0501, 0.001), 3))
