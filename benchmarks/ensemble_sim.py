"""Independent simulator of phase- and parameter-varying joint stiffness trials.

Written without reading the identification method; numpy + scipy only. Every random draw comes
from ``np.random.default_rng(seed)``. Signals are computed on a 2 kHz grid and sampled at 1 kHz.

Equations (angle theta in rad, torque tau in N·m applied TO the joint, positive towards +theta):

* Reference movement (cosine series, so its velocity is continuous across cycles of unequal
  length): ``theta_r(phi) = a0 + sum_h a_h cos(2 pi h phi)``; phase ``phi = (t - t_k)/(t_{k+1} - t_k)``.
* Angle: ``theta = theta_r(phi) + d(t) + x(t)``; ``d`` is an optional slow drift (two slow sines,
  a few hundredths of a rad), ``x`` the perturbation.
* Joint torque (linearised about the reference): ``tau = tau_bg(phi) + I theta'' + B theta'
  + K(phi) (theta - theta_r(phi)) + r(t) + noise``. The drift is a real change of angle, so the
  spring sees it: the local (incremental) stiffness is K, the quantity to identify.
* Stretch reflex (after Kearney's ankle model): ``r = LP2[ G(phi) max(x'(t - 40 ms) - v_th, 0) ]``,
  the delayed stretch velocity (relative to the planned movement), half-wave rectified above
  v_th = 0.01 rad/s, through a 2nd-order low-pass (3.5 Hz, zeta 0.7); the gain G is high in the
  stance-like part of the cycle (parameter-varying: rises with the operating position).
* Position-controlled device ("prbs", "continuous"): ``x`` is the command (a random binary
  sequence on a 40 ms clock, or band-limited Gaussian noise) through the actuator: an 80 Hz lag
  ``z' = p (u - z)`` then ``x'' = wa^2 (z - x) - 2 zeta wa x'`` (wa 20-40 Hz, zeta 0.7), discretised
  exactly (zero-order hold on u), so theta, theta', theta'' are exact (acceleration continuous)
  and tau follows algebraically.
* Torque-controlled device ("torque"): the device applies ``tau_bg + I (theta_r + d)'' + B (theta_r
  + d)' + K d`` plus a filtered random-binary torque ``p``; then ``I x'' + B x' + K(phi) x + r = p``
  is integrated by RK4 with 1 ms steps (inputs known at the half steps), and tau is the device torque.
* Parameter-varying trials: ``theta = s(t) + x(t)`` with a slow sweep s recorded as its own channel;
  ``tau = T(s) + I theta'' + B theta' + K(s) (theta - s) + r + noise`` with ``T' = K`` (K exponential
  or sigmoid in s, 15 -> 85 N·m/rad).
* Recording: torque noise N(0, (1-3 % sd(tau))^2); angle quantised to 2^16 counts/rev.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

FS = 1000.0          # output sampling rate, Hz
FINE = 2             # simulation grid = FINE * FS
Q_ANGLE = 2 * np.pi / 2 ** 16
POLE_HZ = 80.0       # actuator drive lag ahead of its 2nd-order stage
DELAY, V_TH = 0.040, 0.01  # reflex delay (s) and stretch-velocity threshold (rad/s)
JOINTS = {  # inertia, damping ranges; stiffness scale; movement centre; background torque
    "ankle": dict(inertia=(0.01, 0.02), damping=(0.5, 1.5), kscale=1.0, centre=0.0,
                  bg=(-3.0, -20.0), reflex=(2.0, 5.0)),
    "elbow": dict(inertia=(0.04, 0.08), damping=(0.3, 1.0), kscale=0.4, centre=1.2,
                  bg=(2.0, 4.0), reflex=(0.5, 1.5)),
}


@dataclass(frozen=True)
class EnsembleTrial:
    """One simulated trial and its ground truth (see the module docstring)."""

    name: str
    time: np.ndarray
    angle: np.ndarray
    torque: np.ndarray
    marker: np.ndarray
    schedule: np.ndarray
    phase: np.ndarray
    stiffness: np.ndarray
    inertia: float
    damping: float
    period_s: float | None
    truth_grid: np.ndarray
    truth_curve: np.ndarray
    params: dict = field(default_factory=dict)


def _bump(phi, centre=0.3, width=0.22):
    """Broad, flat-topped periodic bump (stance-like), 1 at ``centre``, ~0 half a cycle away."""
    dist = (np.asarray(phi) - centre + 0.5) % 1.0 - 0.5
    return np.exp(-(np.abs(dist) / width) ** 4)


def _smoothstep(z):
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(z, 0.0, 1.0))


def _stiffness_fn(shape, joint, rng):
    """Return (K(phi) callable, settings dict) for a stiffness shape."""
    sc = JOINTS[joint]["kscale"]
    if shape == "sinusoidal":
        k0, a, ph = sc * rng.uniform(50, 70), rng.uniform(0.4, 0.6), rng.uniform(0, 2 * np.pi)
        return (lambda p: k0 * (1 + a * np.sin(2 * np.pi * p + ph)),
                dict(k0=k0, amplitude=a, phase_offset=ph))
    if shape == "gait":
        lo, hi = sc * 15.0, sc * 110.0
        return (lambda p: lo + (hi - lo) * _bump(p), dict(k_low=lo, k_high=hi, peak=0.3, width=0.22))
    if shape == "steps":
        n_lev = int(rng.integers(2, 4))
        levels = sc * (np.array([30.0, 90.0, 55.0])[:n_lev] * rng.uniform(0.9, 1.1, n_lev))
        bounds = np.sort(rng.uniform(0.1, 0.85, n_lev))
        while np.any(np.diff(bounds) < 0.15):
            bounds = np.sort(rng.uniform(0.1, 0.85, n_lev))
        seq = np.append(levels, levels[0])  # level i+1 after bound i; level 0 before/after
        w = 0.03

        def k(p):
            out = np.full(np.shape(p), seq[0], dtype=float)
            for b, lo_, hi_ in zip(bounds, seq[:-1], seq[1:]):
                out = out + (hi_ - lo_) * _smoothstep((np.asarray(p) - b) / w + 0.5)
            return out
        return k, dict(levels=levels.tolist(), bounds=bounds.tolist(), transition=w)
    raise ValueError(f"unknown shape {shape!r}")


def _reference(joint, rng):
    """Cosine-series reference movement: coefficients (a0, a_1..a_3) scaled to +-amp rad."""
    amp = rng.uniform(0.1, 0.2)
    if joint == "ankle":  # gait-like: plantarflex at loading, dorsiflex in stance, push-off
        c = np.array([0.45, -0.35, 0.2])
    else:                 # reaching-like out and back: (1 - cos)/2
        c = np.array([-1.0, 0.0, 0.0])
    g = np.cos(2 * np.pi * np.outer(np.linspace(0, 1, 2001), [1, 2, 3])) @ c
    c = c * 2 * amp / (g.max() - g.min())
    a0 = JOINTS[joint]["centre"] - 0.5 * (g.max() + g.min()) * 2 * amp / (g.max() - g.min())
    return a0, c, amp


def _ref_eval(phi, rate, a0, c):
    """theta_r and its first two time derivatives for phase ``phi`` advancing at ``rate`` 1/s."""
    h = 2 * np.pi * np.arange(1, len(c) + 1)
    arg = np.outer(phi, h)
    pos = a0 + np.cos(arg) @ c
    vel = -(np.sin(arg) @ (c * h)) * rate
    acc = -(np.cos(arg) @ (c * h ** 2)) * rate ** 2
    return pos, vel, acc


def _lowpass2_ss(f_hz, zeta, dt, pole_hz=None):
    """Exact ZOH discretisation of y'' = w^2 (z - y) - 2 zeta w y', z' = p (u - z) (z = u when
    ``pole_hz`` is None); states (y, y'[, z]); returns (Ad, Bd, w)."""
    w = 2 * np.pi * f_hz
    if pole_hz is None:
        a, b = np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]]), np.array([[0.0], [w * w]])
    else:
        p = 2 * np.pi * pole_hz
        a = np.array([[0.0, 1.0, 0.0], [-w * w, -2 * zeta * w, w * w], [0.0, 0.0, -p]])
        b = np.array([[0.0], [0.0], [p]])
    m = len(a)
    ad, bd, *_ = signal.cont2discrete((a, b, np.eye(m), np.zeros((m, 1))), dt, method="zoh")
    return ad, bd[:, 0], w


def _lowpass2(u, f_hz, zeta, dt, pole_hz=None):
    """Filter a held input exactly; returns y, y', y'' at the grid points.

    With ``pole_hz`` a first-order lag (the actuator's drive) precedes the 2nd-order stage, so the
    acceleration is continuous.
    """
    ad, bd, w = _lowpass2_ss(f_hz, zeta, dt, pole_hz)
    out = []
    for row in range(len(ad)):  # transfer function u -> state[row] by lfilter (vectorised)
        num, den = signal.ss2tf(ad, bd[:, None], np.eye(len(ad))[row:row + 1], np.zeros((1, 1)))
        out.append(signal.lfilter(num[0], den, u))  # strictly proper: state k sees u[0..k-1]
    drive = u if pole_hz is None else out[2]
    return out[0], out[1], w * w * (drive - out[0]) - 2 * zeta * w * out[1]


def _binary(n_ms, rng, clock_ms=40):
    """Random binary +-1 sequence per ms: a 40 ms clock, each tick switches with probability 1/2."""
    ticks = rng.random(n_ms // clock_ms + 2) < 0.5
    levels = np.where(np.cumsum(ticks) % 2 == 0, 1.0, -1.0)
    return np.repeat(levels, clock_ms)[:n_ms]


def _command(kind, n_ms, rng):
    """Unit-scale perturbation command held over each 1 ms sample."""
    if kind in ("prbs", "torque"):
        return _binary(n_ms, rng)
    if kind == "continuous":
        b, a = signal.butter(4, rng.uniform(8, 15), fs=FS)
        u = signal.lfilter(b, a, rng.standard_normal(n_ms + 500))[500:]
        return u / (2.0 * u.std())  # sd 0.5, so +-1 is about 2 sd
    raise ValueError(f"unknown perturbation {kind!r}")


def _reflex_from_velocity(vel, gain, delay_s, v_th, dt):
    """Delayed, rectified, gain-modulated stretch velocity through the reflex low-pass."""
    nd = int(round(delay_s / dt))
    u = np.concatenate([np.zeros(nd), np.maximum(vel[:-nd] - v_th, 0.0)]) * gain
    return _lowpass2(u, 3.5, 0.7, dt)[0]


def _drift(t, total, rng):
    """Slow drift of the operating point and its derivatives (two slow sines, starts at 0)."""
    size, p1, p2 = rng.uniform(0.02, 0.04), rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi)
    w1, w2 = np.pi / total, 3 * np.pi / total
    d = size * (0.7 * np.sin(w1 * t + p1) + 0.3 * np.sin(w2 * t + p2) - 0.7 * np.sin(p1) - 0.3 * np.sin(p2))
    dv = size * (0.7 * w1 * np.cos(w1 * t + p1) + 0.3 * w2 * np.cos(w2 * t + p2))
    da = -size * (0.7 * w1 ** 2 * np.sin(w1 * t + p1) + 0.3 * w2 ** 2 * np.sin(w2 * t + p2))
    return d, dv, da, size


def _integrate_torque_mode(p_f, k_f, gain, inertia, damping, delay_s, v_th, dt):
    """RK4 of I x'' + B x' + K(t) x + r = p at 1 ms steps; p, K given on the 2 kHz grid.

    The reflex r depends on x' 40 ms earlier, so it is advanced with its exact ZOH recursion
    each step and interpolated linearly inside the step.
    """
    n = (len(p_f) + 1) // 2
    ad, bd, _ = _lowpass2_ss(3.5, 0.7, dt)
    nd = int(round(delay_s / dt))
    x, v, rs0, rs1 = 0.0, 0.0, 0.0, 0.0
    xs, vs, rr = np.zeros(n), np.zeros(n), np.zeros(n)
    inv_i = 1.0 / inertia
    for i in range(n - 1):
        u = gain[i] * max(vs[i - nd] - v_th, 0.0) if i >= nd else 0.0
        n0 = ad[0, 0] * rs0 + ad[0, 1] * rs1 + bd[0] * u
        rs1 = ad[1, 0] * rs0 + ad[1, 1] * rs1 + bd[1] * u
        r_a, r_b = rr[i], n0
        rs0 = n0
        j = 2 * i
        f_a, f_m, f_b = p_f[j] - r_a, p_f[j + 1] - 0.5 * (r_a + r_b), p_f[j + 2] - r_b
        k_a, k_m, k_b = k_f[j], k_f[j + 1], k_f[j + 2]
        a1 = (f_a - damping * v - k_a * x) * inv_i
        x2, v2 = x + 0.5 * dt * v, v + 0.5 * dt * a1
        a2 = (f_m - damping * v2 - k_m * x2) * inv_i
        x3, v3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2
        a3 = (f_m - damping * v3 - k_m * x3) * inv_i
        x4, v4 = x + dt * v3, v + dt * a3
        a4 = (f_b - damping * v4 - k_b * x4) * inv_i
        x += dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v += dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        xs[i + 1], vs[i + 1], rr[i + 1] = x, v, r_b
    return xs, vs, rr


def _record(torque_clean, angle_clean, rng):
    """Add torque sensor noise (1-3 % of its sd) and quantise the angle (2^16 counts/rev)."""
    frac = rng.uniform(0.01, 0.03)
    torque = torque_clean + rng.normal(0.0, frac * torque_clean.std(), torque_clean.size)
    return torque, np.round(angle_clean / Q_ANGLE) * Q_ANGLE, frac


def _cycle_starts(n_cycles, period_s, unequal, rng):
    """Cycle start times with an extra partial cycle before and after the recorded ones."""
    jit = rng.uniform(0.05, 0.10) if unequal else 0.0
    periods = period_s * (1 + rng.uniform(-jit, jit, n_cycles + 2))
    starts = np.concatenate([[0.0], np.cumsum(periods)])
    lead = rng.uniform(0.3, 0.7) * periods[0]  # recording starts inside the cycle before
    t0, t_end = starts[1] - (periods[0] - lead), starts[-2] + rng.uniform(0.3, 0.7) * periods[-1]
    return starts - t0, t_end - t0, jit


def _respond(kind, joint, k_f, gain, inertia, damping, k_mean, rng):
    """Perturbation x (1 kHz) and its torque ``I x'' + B x' + K x + r`` for the device ``kind``.

    ``k_f`` is K on the 2 kHz grid, ``gain`` the reflex gain at 1 kHz (zeros: no reflex).
    """
    n_ms = (k_f.size - 1) // FINE + 1
    f_act, dt_f = rng.uniform(20, 40), 1.0 / (FS * FINE)
    cmd = np.repeat(_command(kind, n_ms, rng), FINE)[: k_f.size]
    if kind == "torque":
        p_amp = 0.025 * k_mean  # N·m: about 0.025 rad of static deflection
        p_f = _lowpass2(p_amp * cmd, f_act, 0.7, dt_f, POLE_HZ)[0]
        x, _, _ = _integrate_torque_mode(p_f, k_f, gain, inertia, damping, DELAY, V_TH, 1.0 / FS)
        return x, p_f[::FINE], dict(actuator_hz=f_act, perturbation_amplitude=p_amp)
    p_amp = rng.uniform(0.015, 0.03) if joint == "ankle" else rng.uniform(0.02, 0.04)
    x, xv, xa = (q[::FINE] for q in _lowpass2(p_amp * cmd, f_act, 0.7, dt_f, POLE_HZ))
    r = _reflex_from_velocity(xv, gain, DELAY, V_TH, 1.0 / FS) if np.any(gain) else 0.0
    tau_x = inertia * xa + damping * xv + k_f[::FINE] * x + r
    return x, tau_x, dict(actuator_hz=f_act, perturbation_amplitude=p_amp)


def ensemble(shape: str, *, n_cycles: int, period_s: float, seed: int, perturbation: str = "prbs",
             reflex: bool = False, drift: bool = False, unequal: bool = False,
             joint: str = "ankle") -> EnsembleTrial:
    """Simulate a repeated-cycle trial whose stiffness varies with the cycle's phase.

    Parameters
    ----------
    shape : {"sinusoidal", "gait", "steps"}
        Shape of K(phase).
    n_cycles, period_s : int, float
        Number of whole recorded cycles and their nominal period (s).
    seed : int
        Seed of ``np.random.default_rng``; everything random is drawn from it.
    perturbation : {"prbs", "continuous", "torque"}
        Position-controlled random binary or band-limited noise, or a torque-controlled
        random-binary torque.
    reflex, drift, unequal : bool
        Phase-modulated stretch reflex; slow drift of the mean angle; periods jittered 5-10 %.
    joint : {"ankle", "elbow"}

    Returns
    -------
    EnsembleTrial
    """
    rng = np.random.default_rng(seed)
    spec = JOINTS[joint]
    inertia, damping = rng.uniform(*spec["inertia"]), rng.uniform(*spec["damping"])
    kfun, kpar = _stiffness_fn(shape, joint, rng)
    a0, coef, amp = _reference(joint, rng)
    starts, t_end, jit = _cycle_starts(n_cycles, period_s, unequal, rng)
    n_ms = int(np.floor(t_end * FS)) + 1
    t_f = np.arange((n_ms - 1) * FINE + 1) / (FS * FINE)
    k_idx = np.searchsorted(starts, t_f, side="right") - 1
    rate = 1.0 / (starts[k_idx + 1] - starts[k_idx])
    phi = (t_f - starts[k_idx]) * rate
    th_r, thv_r, tha_r = (q[::FINE] for q in _ref_eval(phi, rate, a0, coef))
    d, dv, da, d_size = _drift(t_f[::FINE], t_f[-1], rng) if drift else (0.0, 0.0, 0.0, 0.0)
    k_f = kfun(phi)
    k, ph = k_f[::FINE], phi[::FINE]
    g0 = rng.uniform(*spec["reflex"]) if reflex else 0.0
    x, tau_x, pert = _respond(perturbation, joint, k_f, g0 * (0.25 + 0.75 * _bump(ph)),
                              inertia, damping, float(np.mean(kfun(np.linspace(0, 1, 201)))), rng)
    tau = (spec["bg"][0] + spec["bg"][1] * _bump(ph) + inertia * (tha_r + da)
           + damping * (thv_r + dv) + k * d + tau_x)
    torque, angle_rec, noise_frac = _record(tau, th_r + d + x, rng)
    t = t_f[::FINE]
    starts_in = starts[(starts >= 0) & (starts <= t[-1])]
    marker = np.zeros(n_ms)
    for st in starts_in:
        marker[int(np.ceil(st * FS - 1e-9)):][:10] = 1.0
    phase = np.where((t >= starts_in[0]) & (t < starts_in[-1]), ph, np.nan)
    grid = np.linspace(0.0, 1.0, 201)
    params = dict(kind="ensemble", shape=shape, n_cycles=n_cycles, period_s=period_s, seed=seed,
                  perturbation=perturbation, reflex=reflex, drift=drift, unequal=unequal,
                  joint=joint, stiffness=kpar, movement_amplitude=amp, movement_centre=a0,
                  movement_coef=coef.tolist(), period_jitter=jit, drift_size=d_size,
                  reflex_gain=g0, reflex_delay_s=DELAY, reflex_threshold=V_TH,
                  torque_noise_frac=noise_frac, angle_counts_per_rev=2 ** 16,
                  cycle_starts_s=starts_in.tolist(), **pert)
    name = f"ens_{joint}_{shape}_{perturbation}_n{n_cycles}" + "".join(
        f"_{k}" for k, on in (("reflex", reflex), ("drift", drift), ("unequal", unequal)) if on)
    return EnsembleTrial(name=name, time=t, angle=angle_rec, torque=torque, marker=marker,
                         schedule=a0 + d + np.zeros(n_ms), phase=phase, stiffness=k,
                         inertia=float(inertia), damping=float(damping), period_s=float(period_s),
                         truth_grid=grid, truth_curve=kfun(grid), params=params)


def _sweep(t, total, kind, lo=-0.4, hi=0.2):
    """Slow operating position s(t) and its derivatives: cycloidal ramp or cosine back-and-forth."""
    if kind == "ramp":
        w = 2 * np.pi / total
        s = lo + (hi - lo) * (t / total - np.sin(w * t) / (2 * np.pi))
        sv = (hi - lo) * (1 - np.cos(w * t)) / total
        sa = (hi - lo) * w * np.sin(w * t) / total
    elif kind == "back_and_forth":
        w = 2 * np.pi * 2 / total  # two full sweeps up and down
        s = 0.5 * (lo + hi) - 0.5 * (hi - lo) * np.cos(w * t)
        sv, sa = 0.5 * (hi - lo) * w * np.sin(w * t), 0.5 * (hi - lo) * w ** 2 * np.cos(w * t)
    else:
        raise ValueError(f"unknown sweep {kind!r}")
    return s, sv, sa


def _k_of_s(form, lo=-0.4, hi=0.2, k_lo=15.0, k_hi=85.0):
    """K(s) and its integral T(s) (the static torque) for an exponential or sigmoid form."""
    if form == "exponential":
        c = np.log(k_hi / k_lo) / (hi - lo)
        return (lambda s: k_lo * np.exp(c * (s - lo)),
                lambda s: k_lo / c * (np.exp(c * (s - lo)) - 1))
    mid, width = 0.5 * (lo + hi), (hi - lo) / 8
    return (lambda s: k_lo + (k_hi - k_lo) / (1 + np.exp(-(s - mid) / width)),
            lambda s: k_lo * (s - lo) + (k_hi - k_lo) * width * (
                np.logaddexp(0, (s - mid) / width) - np.logaddexp(0, (lo - mid) / width)))


def parameter_varying(*, seed: int, duration_s: float = 100.0, reflex: bool = False,
                      sweep: str = "ramp") -> EnsembleTrial:
    """Simulate an ankle trial whose stiffness follows a slowly swept operating position.

    Parameters
    ----------
    seed : int
    duration_s : float
        Trial length; the sweep spans it (ramp: -0.4 -> 0.2 rad; back_and_forth: twice up and down).
    reflex : bool
        Stretch reflex with a gain rising with the operating position (dorsiflexion).
    sweep : {"ramp", "back_and_forth"}

    Returns
    -------
    EnsembleTrial
        ``schedule`` is the recorded slow position (0.002 rad noise); truth against it.
    """
    rng = np.random.default_rng(seed)
    spec = JOINTS["ankle"]
    inertia, damping = rng.uniform(*spec["inertia"]), rng.uniform(*spec["damping"])
    form = ("exponential", "sigmoid")[int(rng.integers(2))]
    kfun, tfun = _k_of_s(form)
    n = int(round(duration_s * FS)) + 1
    t_f = np.arange((n - 1) * FINE + 1) / (FS * FINE)
    s, sv, sa = (q[::FINE] for q in _sweep(t_f, t_f[-1], sweep))
    g0 = rng.uniform(*spec["reflex"]) if reflex else 0.0
    x, tau_x, pert = _respond("prbs", "ankle", kfun(_sweep(t_f, t_f[-1], sweep)[0]),
                              g0 * (0.3 + 0.7 * (s + 0.4) / 0.6), inertia, damping, 0.0, rng)
    k, t_off = kfun(s), rng.uniform(-15, -5)
    tau = t_off + tfun(s) + inertia * sa + damping * sv + tau_x
    torque, angle_rec, noise_frac = _record(tau, s + x, rng)
    sched = s + rng.normal(0.0, 0.002, n)
    grid = np.linspace(-0.4, 0.2, 121)
    params = dict(kind="parameter_varying", seed=seed, duration_s=duration_s, reflex=reflex,
                  sweep=sweep, k_form=form, k_range=(15.0, 85.0), sweep_range=(-0.4, 0.2),
                  reflex_gain=g0, reflex_delay_s=DELAY, reflex_threshold=V_TH, torque_offset=t_off,
                  torque_noise_frac=noise_frac, schedule_noise_sd=0.002, angle_counts_per_rev=2 ** 16,
                  **pert)
    return EnsembleTrial(name=f"pv_ankle_{sweep}_{form}" + ("_reflex" if reflex else ""),
                         time=t_f[::FINE],
                         angle=angle_rec, torque=torque, marker=np.zeros(n), schedule=sched,
                         phase=np.full(n, np.nan), stiffness=k, inertia=float(inertia),
                         damping=float(damping), period_s=None, truth_grid=grid,
                         truth_curve=kfun(grid), params=params)


def write_csv(trial: EnsembleTrial, path) -> None:
    """Write ``time_s,angle_rad,torque_Nm,marker,schedule_rad`` rows with ``%.9g``."""
    data = np.column_stack([trial.time, trial.angle, trial.torque, trial.marker, trial.schedule])
    np.savetxt(path, data, fmt="%.9g", delimiter=",", header="time_s,angle_rad,torque_Nm,marker,schedule_rad",
               comments="")


def cases(quick: bool = False) -> list[tuple[str, dict]]:
    """Benchmark cases as (name, kwargs); kwargs with "shape" go to ``ensemble``, else to
    ``parameter_varying`` (or call ``make``)."""
    out, seed = [], 9100
    n_list = [20, 40] if quick else [20, 40, 100, 200]
    i = 0
    for shape in ("sinusoidal", "gait", "steps"):
        for pert in ("prbs", "continuous"):
            for n in (n_list if not quick else n_list[i % 2:i % 2 + 1]):
                kw = dict(shape=shape, n_cycles=n, period_s=(1.0, 1.5, 2.0)[i % 3], seed=seed + i,
                          perturbation=pert, reflex=i % 3 == 1, drift=i % 4 == 2, unequal=i % 2 == 1,
                          joint="ankle" if i % 5 else "elbow")
                out.append((f"ens{i:02d}_{kw['joint']}_{shape}_{pert}_n{n}", kw))
                i += 1
    extra = [("gait", "ankle", True), ("sinusoidal", "elbow", False)]
    for shape, joint, rfx in (extra[:1] if quick else extra):
        kw = dict(shape=shape, n_cycles=40, period_s=1.5, seed=seed + i, perturbation="torque",
                  reflex=rfx, drift=False, unequal=True, joint=joint)
        out.append((f"ens{i:02d}_{joint}_{shape}_torque_n40", kw))
        i += 1
    for sweep in ("ramp", "back_and_forth"):
        for rfx in (False, True):
            kw = dict(seed=seed + i, duration_s=40.0 if quick else 100.0, reflex=rfx, sweep=sweep)
            out.append((f"pv{i:02d}_{sweep}" + ("_reflex" if rfx else ""), kw))
            i += 1
    return out


def make(kwargs: dict) -> EnsembleTrial:
    """Build the trial of one ``cases()`` entry."""
    return ensemble(**kwargs) if "shape" in kwargs else parameter_varying(**kwargs)
