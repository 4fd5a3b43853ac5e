"""The 1-DOF joint and its two drives.

Equation of motion (Grioli & Bicchi 2010, eq. (6), plus unmodelled terms)::

    m·ÿ + d(ẏ) + s(y, u(t)) + e(y, ẏ, z, ẏ(t − δ)) = τ_ext(t)

with inertia m, damping torque d (generalized damping ∂d/∂ẏ), elastic torque s with
stiffness σ = ∂s/∂y, a stiffness-regulating input u(t), and an optional effect torque e
(friction, reflex, hysteresis state z…). Two drives:

* **torque drive** — τ_ext(t) is given and the ODE is integrated by fixed-step RK4 on an
  internal grid (``internal_step``); delayed velocity is read from the stored history
  (method of steps, cubic Hermite at half steps);
* **position drive** — y(t) is imposed (a perturbation platform), its derivatives are
  analytic, and τ_ext follows from the equation without integration.

Functions written for both floats and arrays take ``lib`` (:mod:`math` or :mod:`numpy`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from ..effects.simulated import DynamicsTerm
from .truth import TrueSignals


@dataclass(frozen=True)
class Joint:
    """Mechanical model of the joint (nominal values).

    Parameters
    ----------
    inertia : float
        m, kg·m² (kg for translational springs).
    damping_torque : callable (v, lib) -> N·m
        d(ẏ).
    damping_slope : callable (v, lib) -> N·m·s/rad
        Generalized damping ∂d/∂ẏ.
    elastic_torque : callable (y, u, lib) -> N·m
        s(y, u).
    stiffness : callable (y, u, lib) -> N·m/rad
        σ = ∂s/∂y, analytic.
    scalar_torque : callable (y, v, u) -> N·m, optional
        d(v) + s(y, u) for floats in one call (speeds up the RK4 loop).
    """

    inertia: float
    damping_torque: Callable
    damping_slope: Callable
    elastic_torque: Callable
    stiffness: Callable
    scalar_torque: Callable | None = None


@dataclass(frozen=True)
class Setup:
    """A scenario made concrete: the joint, its input u(t) and its drive.

    Exactly one of ``external_torque`` (torque drive) and ``trajectory`` (position drive)
    is given (with a dedicated ``plant``, ``trajectory`` is the imposed device position).

    Parameters
    ----------
    kind : {"rotational", "translational"}
    joint : Joint
    control : callable (t) -> u, ndarray shape (n,)
        Stiffness-regulating input u(t) (activation, rest length, stiffness…).
    external_torque : callable (t) -> N·m, optional
        τ_ext(t) of a torque drive.
    trajectory : callable (t, derivatives) -> ndarray shape (derivatives + 1, n), optional
        y(t) and its derivatives for a position drive.
    initial_angle, initial_velocity : float
        State at t = 0 of a torque drive (rad, rad/s).
    max_stiffness, max_damping : float
        Bounds on |σ| (N·m/rad) and |∂d/∂ẏ| (N·m·s/rad) over the trial, for the step size.
    record_elastic : bool
        Whether the elastic torque is recorded (direct observer variant).
    metadata : Mapping[str, str]
        Scenario-specific entries for ``Trial.metadata``.
    plant : callable (setup, term, t, fs) -> TrueSignals, optional
        A dedicated plant for set-ups that are not one rigid body (a device coupled to the
        limb through a spring, :mod:`.devices`): returns the :class:`TrueSignals` of :func:`run`
        itself.
    unrecorded_angle : callable (t) -> rad, ndarray shape (n,), optional
        The part of the true angle that the angle channel does not record (the operating
        point of a platform that records only the perturbation about it).
    torque_sign : float
        +1: the torque applied *to* the joint is recorded; −1: the reaction torque.
    """

    kind: str
    joint: Joint
    control: Callable
    external_torque: Callable | None = None
    trajectory: Callable | None = None
    initial_angle: float = 0.0
    initial_velocity: float = 0.0
    max_stiffness: float = 0.0
    max_damping: float = 0.0
    record_elastic: bool = False
    metadata: Mapping[str, str] = field(default_factory=dict)
    plant: Callable | None = None
    unrecorded_angle: Callable | None = None
    torque_sign: float = 1.0


def internal_step(fs: float, inertia: float, max_stiffness: float,
                  max_damping: float) -> tuple[float, int]:
    """Internal RK4 step h and substeps per sample.

    h ≤ Ts/4, h ≤ 1/(20·f_n) with f_n = √(σ_max/m)/2π the highest natural frequency, and
    h·b_max/m ≤ 0.5 (well inside RK4's stability region for the damping).

    Returns
    -------
    h : float, s
    substeps : int
    """
    ts = 1.0 / fs
    bounds = [ts / 4.0]
    if max_stiffness > 0:
        bounds.append(2.0 * math.pi / (20.0 * math.sqrt(max_stiffness / inertia)))
    if max_damping > 0:
        bounds.append(0.5 * inertia / max_damping)
    substeps = max(4, math.ceil(ts / min(bounds) - 1e-9))
    return ts / substeps, substeps


@dataclass(frozen=True)
class GridMotion:
    """The motion on the internal grid t_i = i·h, shape (n_steps + 1,) each: angle y (rad),
    velocity ẏ (rad/s), acceleration ÿ (rad/s²) and the effect's internal state z."""

    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    state: np.ndarray


def integrate_torque_driven(inertia: float, internal_torque: Callable, external_torque: list,
                            h: float, n_steps: int, *, initial_angle: float = 0.0,
                            initial_velocity: float = 0.0, state_rate: Callable | None = None,
                            delay_steps: int = 0) -> GridMotion:
    """Fixed-step RK4 of m·ÿ + f(k, y, ẏ, z, ẏ(t − δ)) = τ_ext.

    Parameters
    ----------
    inertia : float
        m (> 0).
    internal_torque : callable (k, y, v, z, vd) -> float
        All torques on the left-hand side except m·ÿ; ``k`` indexes the half-step grid
        t_k = k·h/2 (so it can read precomputed inputs).
    external_torque : list of float, length 2·n_steps + 1
        τ_ext on the half-step grid.
    h : float
        Step, s.
    n_steps : int
    initial_angle, initial_velocity : float
    state_rate : callable (y, v, z) -> float, optional
        Rate of one internal effect state z (z(0) = 0).
    delay_steps : int
        δ/h; the velocity before t = 0 is taken as 0 (joint at rest). 0 = no delay.

    Returns
    -------
    GridMotion
        On the grid t_i = i·h.
    """
    if inertia <= 0:
        raise ValueError("a torque drive needs a positive inertia")
    if delay_steps and delay_steps < 2:
        raise ValueError("the delay must be at least two internal steps")
    n1 = n_steps + 1
    out = ([0.0] * n1, [0.0] * n1, [0.0] * n1, [0.0] * n1)
    _rk4_steps(out, 1.0 / inertia, internal_torque, external_torque, state_rate, h,
               float(initial_angle), float(initial_velocity), 2 * int(delay_steps))
    return GridMotion(*map(np.array, out))


def _delayed_velocity(vs: list, acc: list, h8: float, j: int) -> float:
    """ẏ at half step ``j`` of the stored history (cubic Hermite between steps; 0 before t = 0).

    ``vs``, ``acc``: velocity (rad/s) and acceleration (rad/s²) at the steps so far; ``h8``: h/8.
    """
    if j < 0:
        return 0.0
    p = j >> 1
    if j & 1 == 0:
        return vs[p]
    return 0.5 * (vs[p] + vs[p + 1]) + h8 * (acc[p] - acc[p + 1])


def _rk4_steps(out: tuple, inv_m: float, f: Callable, tau: list, rate: Callable | None, h: float,
               y: float, v: float, D: int) -> None:
    """The RK4 loop of :func:`integrate_torque_driven`, filling ``out`` in place.

    ``out`` = (angle, velocity, acceleration, state) lists of length n_steps + 1; ``inv_m``
    1/m; ``f``, ``tau``, ``rate`` as there; ``y``, ``v`` the initial state; ``D`` the delay in
    half steps (0: none).
    """
    ys, vs, acc, zs = out
    n_steps = len(ys) - 1
    hh, h6, h8 = 0.5 * h, h / 6.0, h / 8.0
    z = vd1 = vd2 = vd4 = 0.0

    def slope(j: int, y: float, v: float, z: float, vd: float) -> tuple[float, float]:
        """ÿ and ż at half step ``j`` of the state (y, v, z), the delayed velocity ``vd``."""
        return (tau[j] - f(j, y, v, z, vd)) * inv_m, 0.0 if rate is None else rate(y, v, z)

    for i in range(n_steps):
        k = 2 * i
        ys[i], vs[i], zs[i] = y, v, z
        if D:
            vd1 = _delayed_velocity(vs, acc, h8, k - D)
            vd2 = _delayed_velocity(vs, acc, h8, k + 1 - D)
            vd4 = _delayed_velocity(vs, acc, h8, k + 2 - D)
        a1, r1 = slope(k, y, v, z, vd1)
        acc[i] = a1
        y2, v2, z2 = y + hh * v, v + hh * a1, z + hh * r1
        a2, r2 = slope(k + 1, y2, v2, z2, vd2)
        y3, v3, z3 = y + hh * v2, v + hh * a2, z + hh * r2
        a3, r3 = slope(k + 1, y3, v3, z3, vd2)
        y4, v4, z4 = y + h * v3, v + h * a3, z + h * r3
        a4, r4 = slope(k + 2, y4, v4, z4, vd4)
        y += h6 * (v + 2.0 * (v2 + v3) + v4)
        v += h6 * (a1 + 2.0 * (a2 + a3) + a4)
        z += h6 * (r1 + 2.0 * (r2 + r3) + r4)
    k = 2 * n_steps
    ys[n_steps], vs[n_steps], zs[n_steps] = y, v, z
    vd = _delayed_velocity(vs, acc, h8, k - D) if D else 0.0
    acc[n_steps] = (tau[k] - f(k, y, v, z, vd)) * inv_m


def run(setup: Setup, term: DynamicsTerm, fs: float, duration: float) -> TrueSignals:
    """Simulate a setup with an effect term; true signals at the sample times.

    Parameters
    ----------
    setup : Setup
    term : DynamicsTerm
        ``NO_EFFECT`` for the nominal model.
    fs : float
        Sampling rate, Hz.
    duration : float
        s; samples at t = 0, 1/fs, …, duration.

    Returns
    -------
    TrueSignals
        A dedicated ``setup.plant`` returns its own (with ``limb`` for a coupled limb).
    """
    n = int(round(duration * fs)) + 1
    t = np.arange(n) / fs
    if setup.plant is not None:
        return setup.plant(setup, term, t, fs)
    m = setup.joint.inertia * term.inertia_scale
    if setup.trajectory is not None:
        motion = _position_drive(setup, term, t)
    else:
        motion = _torque_drive(setup, term, t, fs, m)
    return _true_signals(setup, term, t, m, motion)


def unrecorded_angle(setup: Setup, t: np.ndarray) -> np.ndarray:
    """The part of the true angle the set-up's angle channel does not record at the times ``t``
    (s, shape (n,)): rad, shape (n,); zeros for most set-ups."""
    if setup.unrecorded_angle is None:
        return np.zeros(len(t))
    return np.asarray(setup.unrecorded_angle(t), dtype=float)


@dataclass(frozen=True)
class _Motion:
    """The true motion at the sample times, shape (n,) each: y (rad), ẏ, ÿ, jerk (rad/s³), the
    effect state z, the delayed velocity ẏ(t − δ); the internal step h (s, 0 for a position
    drive) and the delay δ actually used (s)."""

    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    state: np.ndarray
    delayed_velocity: np.ndarray
    internal_step: float
    delay: float


def _position_drive(setup: Setup, term: DynamicsTerm, t: np.ndarray) -> _Motion:
    """The imposed motion and its analytic derivatives at the times ``t`` (s, shape (n,))."""
    n = len(t)
    delay = float(term.delay)
    y, v, a, jerk = setup.trajectory(t, 3)
    z = term.state_along(y) if term.state_along is not None else np.zeros(n)
    vd = np.zeros(n)
    if delay > 0:
        late = t >= delay
        vd[late] = setup.trajectory(t[late] - delay, 1)[1]
    return _Motion(y, v, a, jerk, z, vd, 0.0, delay)


def _torque_drive(setup: Setup, term: DynamicsTerm, t: np.ndarray, fs: float,
                  m: float) -> _Motion:
    """The motion under the external torque, by RK4 on the internal grid, at the times ``t``.

    ``m``: the true inertia (kg·m²). The delay is rounded to whole internal steps.
    """
    n = len(t)
    delay = float(term.delay)
    h, sub = internal_step(fs, m, setup.max_stiffness + term.max_stiffness,
                           term.damping_scale * setup.max_damping + term.max_damping)
    n_steps = (n - 1) * sub
    t_half = np.arange(2 * n_steps + 1) * (0.5 * h)
    tau = np.asarray(setup.external_torque(t_half), dtype=float).tolist()
    u = np.broadcast_to(setup.control(t_half), t_half.shape).tolist()
    steps = 0
    if delay > 0:
        steps = max(2, int(round(delay / h)))
        delay = steps * h
    fine = integrate_torque_driven(
        m, _internal_torque(setup.joint, term, u), tau, h, n_steps,
        initial_angle=setup.initial_angle, initial_velocity=setup.initial_velocity,
        state_rate=term.state_rate, delay_steps=steps)
    y, v, a, z = fine.angle[::sub], fine.velocity[::sub], fine.acceleration[::sub], fine.state[::sub]
    jerk = np.gradient(fine.acceleration, h)[::sub]
    vd = np.zeros(n)
    if steps:
        idx = np.arange(n) * sub - steps
        vd[idx >= 0] = fine.velocity[idx[idx >= 0]]
    return _Motion(y, v, a, jerk, z, vd, h, delay)


def _true_signals(setup: Setup, term: DynamicsTerm, t: np.ndarray, m: float,
                  motion: _Motion) -> TrueSignals:
    """The torques, stiffness and damping along the motion (``m``: the true inertia, kg·m²)."""
    joint, b_scale = setup.joint, term.damping_scale
    y, v = motion.angle, motion.velocity
    u = np.broadcast_to(np.asarray(setup.control(t), dtype=float), t.shape).copy()
    elastic = joint.elastic_torque(y, u, np)
    damping_torque = b_scale * joint.damping_torque(v, np)
    effect = (term.torque(y, v, motion.state, motion.delayed_velocity, np)
              if term.torque is not None else np.zeros(len(t)))
    if setup.trajectory is not None:
        external = m * motion.acceleration + damping_torque + elastic + effect
    else:
        external = np.asarray(setup.external_torque(t), dtype=float)
    return TrueSignals(
        time=t, angle=y, velocity=v, acceleration=motion.acceleration, jerk=motion.jerk, control=u,
        elastic_torque=np.broadcast_to(elastic, t.shape).astype(float),
        stiffness=np.broadcast_to(joint.stiffness(y, u, np), t.shape).astype(float),
        generalized_damping=np.broadcast_to(b_scale * joint.damping_slope(v, np), t.shape).astype(float),
        damping_torque=np.broadcast_to(damping_torque, t.shape).astype(float),
        effect_torque=np.broadcast_to(effect, t.shape).astype(float),
        external_torque=external, unrecorded_angle=unrecorded_angle(setup, t), inertia=m,
        internal_step=motion.internal_step, delay=motion.delay)


def _internal_torque(joint: Joint, term: DynamicsTerm, u: list) -> Callable:
    """Scalar f(k, y, v, z, vd) = b_scale·d(v) + s(y, u_k) + e(y, v, z, vd) for the RK4 loop."""
    damp, elastic, effect = joint.damping_torque, joint.elastic_torque, term.torque
    b_scale, lib = term.damping_scale, math
    fused = joint.scalar_torque
    if fused is not None and b_scale == 1.0:
        if effect is None:
            return lambda k, y, v, z, vd: fused(y, v, u[k])
        return lambda k, y, v, z, vd: fused(y, v, u[k]) + effect(y, v, z, vd, lib)
    if effect is None:
        if b_scale == 1.0:
            return lambda k, y, v, z, vd: damp(v, lib) + elastic(y, u[k], lib)
        return lambda k, y, v, z, vd: b_scale * damp(v, lib) + elastic(y, u[k], lib)
    return lambda k, y, v, z, vd: (b_scale * damp(v, lib) + elastic(y, u[k], lib)
                                   + effect(y, v, z, vd, lib))
