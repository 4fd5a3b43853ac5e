"""Independent simulator of joint-stiffness recordings, for testing and benchmarking ``diagnose``.

Standalone (numpy + scipy, numba optional): nothing here is taken from ``limbstiff``.
A single rotational joint follows a prescribed smooth angle trajectory theta(t) and the
device torque is computed from

    m * theta'' = f(t) - b * theta' - tau_elastic(theta, t) - tau_effect(...)

on a 10 kHz grid (stateful effects integrated with fixed-step RK4), then sampled at 1 kHz;
the measurement (encoder quantisation, white noise) is added after sampling.  Each trial
carries at most one unmodelled effect, either in an "independent" (non-textbook) form or in
the "same" (textbook) form; its truth is written beside the CSV as JSON.

Used by the tests and by ``benchmarks/diagnose_independent.py`` and
``benchmarks/calibration_independent.py``. Usage: ``python tests/support/independent_trials.py OUTDIR
[--seed 7100]``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
from scipy import signal

try:  # numba only speeds up the RK4 loops; results are identical without it
    from numba import njit as _njit
except ImportError:  # pragma: no cover
    def _njit(fn):
        return fn

H = 1e-4          # integration step, s (10 kHz)
DECIM = 10        # 10 kHz -> 1 kHz
PRE_S = 1.0       # pre-roll discarded before t = 0, s (transients, delays)
POST_S = 0.1      # margin after the end, s

# form -> (tool effect name, family)
FORMS = {**{f: (e, "independent") for f, e in [
    ("lugre", "coulomb_friction"), ("stribeck", "coulomb_friction"), ("boucwen", "hysteresis"),
    ("reflexact", "reflex"), ("angledelay", "time_delay"), ("quaddampsat", "quadratic_damping")]},
    **{f: (e, "same") for f, e in [
        ("coulomb", "coulomb_friction"), ("quaddamp", "quadratic_damping"),
        ("dahl", "hysteresis"), ("torquedelay", "time_delay"), ("reflex", "reflex")]}}
JOINTS = {  # inertia range kg m^2, damping range N m s/rad
    "elbow": ((0.05, 0.10), (0.3, 0.8)),
    "ankle": ((0.02, 0.05), (0.5, 1.5)),
    "vsa": ((0.008, 0.012), (0.04, 0.06)),
}


@dataclass(frozen=True)
class TrialSpec:
    """One simulated trial (everything random is drawn from ``seed``).

    Parameters
    ----------
    name, family : str
        Trial (file stem) name; ``"independent"``, ``"same"`` or ``"clean"``.
    form : str or None
        Effect form, a key of ``FORMS``; None for a clean trial.
    joint, course : str
        ``"elbow"``, ``"ankle"`` or ``"vsa"``; stiffness course ``"constant"``,
        ``"cocontraction"``, ``"ramp"``, ``"gait"`` or ``"vsa"`` (antagonistic springs).
    seed : int
        Seed of ``numpy.random.default_rng``.
    cubic : bool
        Add a mild cubic term k3 * (theta - theta0)**3 (N m) to the elastic torque.
    pause_s : float
        Length of a pause with the joint held nearly still, s; 0 for none.
    trajectory : str or None
        ``"multisine"`` or ``"noise"``; None draws one.
    duration_s, fs_hz : float
        Trial length (s) and output sampling rate (Hz; must be 1000).
    """

    name: str
    family: str
    form: str | None
    joint: str
    course: str
    seed: int
    cubic: bool = False
    pause_s: float = 0.0
    trajectory: str | None = None
    duration_s: float = 30.0
    fs_hz: float = 1000.0


@dataclass(frozen=True)
class _Ctx:
    """Prescribed motion and nominal torque on the 10 kHz grid (arrays, SI units)."""

    t: np.ndarray
    theta: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    m: float
    b: float
    elastic: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    f_nom: np.ndarray
    idx: np.ndarray  # fine-grid indices of the 1 kHz output samples


class _Infeasible(Exception):
    """The drawn trajectory cannot reach the requested effect size."""


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@_njit
def _rhs(kind, x, u, p):
    """Right-hand side of one scalar state ODE; ``u`` is the input (velocity, rad/s)."""
    if kind == 0:  # LuGre bristle: p = (sigma0, Fc, Fs, vs)
        g = p[1] + (p[2] - p[1]) * math.exp(-(u / p[3]) ** 2)
        return u - p[0] * abs(u) * x / g
    if kind == 1:  # Bouc-Wen: p = (A, beta, gamma, n)
        az = abs(x)
        return p[0] * u - p[1] * abs(u) * az ** (p[3] - 1.0) * x - p[2] * u * az ** p[3]
    if kind == 2:  # Dahl: dz/d|theta| = (sign(v) F - z) / theta_c, p = (F, theta_c)
        return (u * p[0] - abs(u) * x) / p[1]
    return (u - x) / p[0]  # first-order lag, p = (tau,)


@_njit
def _rk4(kind, u, h, p, x0):
    """Fixed-step RK4 of ``_rhs`` along input ``u`` (midpoint input = mean of nodes)."""
    n = u.size
    x = np.empty(n)
    xi = x0
    x[0] = xi
    for i in range(n - 1):
        um = 0.5 * (u[i] + u[i + 1])
        k1 = _rhs(kind, xi, u[i], p)
        k2 = _rhs(kind, xi + 0.5 * h * k1, um, p)
        k3 = _rhs(kind, xi + 0.5 * h * k2, um, p)
        k4 = _rhs(kind, xi + h * k3, u[i + 1], p)
        xi = xi + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        x[i + 1] = xi
    return x


def _shift(x: np.ndarray, n: int) -> np.ndarray:
    """Delay ``x`` by ``n`` fine-grid samples (holding the first value)."""
    if n <= 0:
        return x.copy()
    return np.concatenate([np.full(n, x[0]), x[:-n]])


def _smooth_random(rng, t: np.ndarray, fmin: float, fmax: float) -> np.ndarray:
    """Smooth random process: 4-6 random sinusoids in [fmin, fmax] Hz, max |s| = 1."""
    s = np.zeros_like(t)
    for _ in range(int(rng.integers(4, 7))):
        s += rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * rng.uniform(fmin, fmax) * t
                                            + rng.uniform(0, 2 * np.pi))
    return s / np.max(np.abs(s))


def _pause_window(rng, t: np.ndarray, pause_s: float, dur: float):
    """Window ~1, dropping to 0.02 over a ``pause_s`` s flat pause (0.5 s cosine ramps)."""
    t1 = rng.uniform(5.0, dur - pause_s - 5.0)
    t2, r = t1 + pause_s, 0.5
    bump = np.clip(np.minimum((t - (t1 - r)) / r, ((t2 + r) - t) / r), 0.0, 1.0)
    bump = 0.5 - 0.5 * np.cos(np.pi * bump)
    return 1.0 - 0.98 * bump, (float(t1), float(t2))


def _trajectory(rng, spec: TrialSpec, t: np.ndarray, out: np.ndarray):
    """Prescribed angle (rad), velocity (rad/s), acceleration (rad/s^2) and info."""
    kind = spec.trajectory or ("multisine" if rng.random() < 0.5 else "noise")
    info: dict = {"trajectory": kind}
    if kind == "multisine":
        x = np.zeros_like(t)
        freqs = np.sort(rng.uniform(0.3, 2.5, int(rng.integers(3, 7))))
        for f in freqs:
            x += rng.uniform(0.5, 1.0) / np.sqrt(f) * np.sin(2 * np.pi * f * t
                                                             + rng.uniform(0, 2 * np.pi))
        info["frequencies_hz"] = [float(f) for f in freqs]
    else:
        fc = rng.uniform(2.0, 4.0)
        sos = signal.butter(4, [0.2, fc], btype="bandpass", fs=1.0 / H, output="sos")
        x = signal.sosfiltfilt(sos, rng.standard_normal(t.size))
        info["band_hz"] = [0.2, float(fc)]
    if spec.pause_s > 0:
        w, (t1, t2) = _pause_window(rng, t, spec.pause_s, spec.duration_s)
        x = x * w
        info["pause_s"] = [t1, t2]
    target = rng.uniform(0.05, 0.15)
    x = (x - x[out].mean()) * target / x[out].std()
    theta = rng.uniform(-0.3, 0.3) + x
    vel = np.gradient(theta, H)
    info["angle_rms_rad"] = float(target)
    return theta, vel, np.gradient(vel, H), info


def _course(rng, course: str, joint: str, t: np.ndarray, dur: float):
    """Stiffness course k(t), N m/rad, and its parameters."""
    ankle = joint == "ankle"
    if course == "constant":
        k0 = rng.uniform(50, 150) if ankle else rng.uniform(20, 40)
        return np.full_like(t, k0), {"k_Nm_per_rad": k0}
    if course == "cocontraction":
        k0 = rng.uniform(60, 100) if ankle else rng.uniform(12, 20)
        amp = rng.uniform(0.45, 0.6) * k0
        k = np.maximum(k0 + amp * _smooth_random(rng, t, 0.1, 0.3), 2.0)
        return k, {"k0_Nm_per_rad": k0, "swing_Nm_per_rad": amp, "band_hz": [0.1, 0.3]}
    if course == "ramp":
        lo, hi = (rng.uniform(50, 60), rng.uniform(120, 140)) if ankle else \
            (rng.uniform(5, 8), rng.uniform(25, 35))
        k1, k2 = (lo, hi) if rng.random() < 0.5 else (hi, lo)
        width, tc = rng.uniform(3, 5), dur / 2 + rng.uniform(-2, 2)
        k = k1 + (k2 - k1) / (1 + np.exp(-(t - tc) * 2 * np.log(9) / width))
        return k, {"k_start": k1, "k_end": k2, "ramp_10_90_s": width, "ramp_centre_s": tc}
    if course == "gait":
        lo, hi, per = rng.uniform(55, 65), rng.uniform(100, 120), rng.uniform(1.1, 1.3)
        k = lo + (hi - lo) * 0.5 * (1 - np.cos(2 * np.pi * t / per + rng.uniform(0, 6.28)))
        return k, {"k_low": lo, "k_high": hi, "period_s": per}
    raise ValueError(f"unknown stiffness course {course!r}")


def _elastic(rng, spec: TrialSpec, t, theta, out):
    """Elastic torque function ``elastic(theta) -> (tau, local stiffness)`` and info."""
    centre = float(np.mean(theta[out]))
    if spec.course == "vsa":
        return _vsa(rng, t, centre)
    k, info = _course(rng, spec.course, spec.joint, t, spec.duration_s)
    theta0 = centre + rng.uniform(-0.02, 0.02)
    k3 = 0.0
    if spec.cubic:  # cubic / linear torque at the RMS angle: 8-15 %
        k3 = rng.uniform(0.08, 0.15) * float(np.median(k)) / _rms(theta[out] - theta0) ** 2
    info.update(theta0_rad=theta0, k3_Nm_per_rad3=k3)

    def elastic(th):
        d = th - theta0
        return k * d + k3 * d ** 3, k + 3 * k3 * d ** 2
    return elastic, info


def _vsa(rng, t, centre):
    """Two antagonistic quadratic (tension-only) springs with motor positions u1 < u2.

    tau = kq ([theta - u1]_+^2 - [u2 - theta]_+^2), local stiffness
    2 kq ([theta - u1]_+ + [u2 - theta]_+) (= 4 kq p while both springs are taut).
    """
    p = 0.17 + 0.10 * _smooth_random(rng, t, 0.1, 0.3)           # pretension, rad
    c = centre + 0.02 * _smooth_random(rng, t, 0.05, 0.2)        # equilibrium, rad
    kq = rng.uniform(10, 20) / (4 * 0.17)                         # N m/rad^2
    u1, u2 = c - p, c + p

    def elastic(th):
        e1, e2 = np.maximum(th - u1, 0.0), np.maximum(u2 - th, 0.0)
        return kq * (e1 ** 2 - e2 ** 2), 2 * kq * (e1 + e2)
    return elastic, {"kq_Nm_per_rad2": kq, "pretension_rad": [0.07, 0.27],
                     "equilibrium_swing_rad": 0.02}


def _additive(c: _Ctx, tau: np.ndarray, params: dict):
    return tau, c.theta, c.f_nom + tau, params


def _form(rng, form: str, c: _Ctx):
    """Return ``(apply, bounds)``; ``apply(scale) -> (tau_eff, angle, torque, params)``.

    ``scale`` is the effect's size parameter (linear or nearly so); ``bounds`` limits it
    (delays) or is None.  ``tau_eff`` enters on the side of ``b * theta'``.
    """
    v, av = c.vel, np.abs(c.vel)
    vrms = _rms(v[c.idx])
    if form in ("lugre", "stribeck"):
        ratio, vs = rng.uniform(1.2, 1.4), rng.uniform(0.02, 0.06)
        z0, zeta = rng.uniform(5e-4, 2e-3), rng.uniform(0.2, 0.5)

        def apply(fc):
            fs = ratio * fc
            g = fc + (fs - fc) * np.exp(-(v / vs) ** 2)
            par = {"Fc_Nm": fc, "Fs_Nm": fs, "vs_rad_per_s": vs}
            if form == "stribeck":
                par["smoothing_rad_per_s"] = 1e-4
                return _additive(c, g * v / (av + 1e-4), par)
            s0 = fc / z0
            s1 = zeta * math.sqrt(s0 * c.m)
            z = _rk4(0, v, H, np.array([s0, fc, fs, vs]), 0.0)
            par.update(sigma0_Nm_per_rad=s0, sigma1_Nms_per_rad=s1, sigma2_Nms_per_rad=0.0)
            return _additive(c, s0 * z + s1 * (v - s0 * av * z / g), par)
        return apply, None
    if form == "boucwen":
        n = float(rng.integers(1, 3))
        zu = rng.uniform(0.3, 0.8) * _rms(c.theta[c.idx] - c.theta[c.idx].mean())
        beta = rng.uniform(0.5, 0.8) / zu ** n
        gamma = 1.0 / zu ** n - beta

        def apply(cz):
            z = _rk4(1, v, H, np.array([1.0, beta, gamma, n]), 0.0)
            return _additive(c, cz * z, {"c_Nm_per_rad": cz, "A": 1.0, "beta": beta,
                                         "gamma": gamma, "n": n, "z_ultimate_rad": zu})
        return apply, None
    if form == "dahl":
        th_c = rng.uniform(0.05, 0.2) * _rms(c.theta[c.idx] - c.theta[c.idx].mean())

        def apply(f):
            z = _rk4(2, v, H, np.array([f, th_c]), 0.0)
            return _additive(c, z, {"F_Nm": f, "theta_c_rad": th_c})
        return apply, None
    return _form_b(rng, form, c, vrms)


def _form_b(rng, form: str, c: _Ctx, vrms: float):
    """Continuation of ``_form``: reflexes, delays, damping, Coulomb friction."""
    v, av = c.vel, np.abs(c.vel)
    if form in ("reflex", "reflexact"):
        sign = float(rng.choice([-1.0, 1.0]))
        nd = int(round(rng.uniform(0.030, 0.060) / H))
        u = np.maximum(sign * _shift(v, nd), 0.0)
        par = {"delay_s": nd * H, "direction": sign}
        if form == "reflexact":
            tau_a, order = rng.uniform(0.020, 0.050), int(rng.integers(1, 3))
            for _ in range(order):
                u = _rk4(3, u, H, np.array([tau_a]), 0.0)
            par.update(activation_time_constant_s=tau_a, activation_order=order)
        return (lambda g: _additive(c, g * sign * u, {"gain_Nms_per_rad": g, **par})), None
    if form == "angledelay":
        def apply(d):
            n = int(round(d / H))
            th, vd, ad = _shift(c.theta, n), _shift(c.vel, n), _shift(c.acc, n)
            nominal = c.m * ad + c.b * vd + c.elastic(th)[0]
            return c.f_nom - nominal, th, c.f_nom, {"delay_s": -n * H, "angle_lag_s": n * H}
        return apply, (0.005, 0.025)
    if form == "torquedelay":
        def apply(d):
            n = int(round(d / H))
            f = _shift(c.f_nom, n)
            return f - c.f_nom, c.theta, f, {"delay_s": n * H, "torque_lag_s": n * H}
        return apply, (0.005, 0.025)
    if form in ("quaddamp", "quaddampsat"):
        vsat = rng.uniform(3.0, 5.0) * vrms if form == "quaddampsat" else math.inf

        def apply(cq):
            par = {"c_Nms2_per_rad2": cq}
            if form == "quaddampsat":
                par["v_sat_rad_per_s"] = vsat
            return _additive(c, cq * v * av / (1 + av / vsat), par)
        return apply, None
    if form == "coulomb":
        veps = rng.uniform(0.01, 0.03)
        return (lambda fc: _additive(c, fc * np.tanh(v / veps),
                                     {"Fc_Nm": fc, "v_eps_rad_per_s": veps})), None
    raise ValueError(f"unknown effect form {form!r}")


def _fraction(res, idx) -> float:
    return _rms(res[0][idx]) / _rms(res[2][idx])


def _calibrate(rng, apply, bounds, idx):
    """Size the effect so that its RMS is 14-30 % of the (noise-free) torque RMS."""
    if bounds is None:
        target = rng.uniform(0.14, 0.30)
        res = apply(1.0)
        s = target / _fraction(res, idx)
        for _ in range(30):
            res = apply(s)
            frac = _fraction(res, idx)
            if abs(frac / target - 1) < 0.003:
                return res
            s *= (target / frac) ** (1.0 / max(1.0 - frac, 0.3))
        raise _Infeasible("effect size did not converge")
    lo, hi = bounds
    f_lo, f_hi = _fraction(apply(lo), idx), _fraction(apply(hi), idx)
    a, b = max(0.14, f_lo), min(0.30, f_hi)
    if a >= b:
        raise _Infeasible(f"delay range gives fractions {f_lo:.3f}-{f_hi:.3f}")
    target = rng.uniform(a, b)
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        if _fraction(apply(mid), idx) < target:
            lo = mid
        else:
            hi = mid
    return apply(0.5 * (lo + hi))


def _simulate(spec: TrialSpec, rng):
    """One attempt at a trial; raises ``_Infeasible`` when the effect cannot be sized."""
    n_out = int(round(spec.duration_s * spec.fs_hz))
    if abs(spec.fs_hz * DECIM * H - 1.0) > 1e-12:
        raise ValueError("fs_hz must be 1000 (10 kHz integration, decimation by 10)")
    i0 = int(round(PRE_S / H))
    t = (np.arange(i0 + n_out * DECIM + int(round(POST_S / H))) - i0) * H
    idx = i0 + DECIM * np.arange(n_out)
    (m_lo, m_hi), (b_lo, b_hi) = JOINTS[spec.joint]
    m, b = rng.uniform(m_lo, m_hi), rng.uniform(b_lo, b_hi)
    theta, vel, acc, tinfo = _trajectory(rng, spec, t, idx)
    elastic, cinfo = _elastic(rng, spec, t, theta, idx)
    tau_el, k_loc = elastic(theta)
    c = _Ctx(t, theta, vel, acc, m, b, elastic, m * acc + b * vel + tau_el, idx)
    if spec.form is None:
        res = (np.zeros_like(t), theta, c.f_nom, {})
    else:
        apply, bounds = _form(rng, spec.form, c)
        res = _calibrate(rng, apply, bounds, idx)
    tau_eff, angle, torque, params = (res[0][idx], res[1][idx], res[2][idx], res[3])
    counts = int(2 ** rng.integers(14, 17))
    q = 2 * np.pi / counts
    angle_sd = rng.uniform(0.2, 1.0) * q
    eff_rms = _rms(tau_eff)
    sd_f = eff_rms / rng.uniform(2.0, 6.0) if spec.form else \
        rng.uniform(0.02, 0.05) * _rms(torque)
    angle_meas = np.round(angle / q) * q + rng.normal(0.0, angle_sd, n_out)
    torque_meas = torque + rng.normal(0.0, sd_f, n_out)
    frac = eff_rms / _rms(torque_meas)
    if spec.form and not 0.11 <= frac <= 0.34:
        raise _Infeasible(f"effect fraction {frac:.3f} out of range")
    data = pd.DataFrame({"time_s": np.arange(n_out) / spec.fs_hz, "angle_rad": angle_meas,
                         "torque_Nm": torque_meas, "stiffness_true_Nm_per_rad": k_loc[idx]})
    effect = FORMS[spec.form][0] if spec.form else None
    truth = {"name": spec.name, "family": spec.family, "effect": effect, "form": spec.form,
             "effect_params": params, "effect_rms_fraction": frac,
             "effect_to_noise": eff_rms / sd_f if spec.form else 0.0,
             "inertia": m, "damping": b, "stiffness_course": spec.course,
             "stiffness_median": float(np.median(k_loc[idx])), "torque_noise_sd": sd_f,
             "encoder_counts": counts, "seed": spec.seed, "joint": spec.joint,
             "angle_noise_sd": angle_sd, "course_params": cinfo, "motion": tinfo,
             "duration_s": spec.duration_s, "fs_hz": spec.fs_hz}
    return data, truth


def make_trial(spec: TrialSpec):
    """Simulate one trial.

    Parameters
    ----------
    spec : TrialSpec
        What to simulate; everything random is drawn from ``spec.seed``.

    Returns
    -------
    data : pandas.DataFrame
        Columns ``time_s`` (s), ``angle_rad`` (rad), ``torque_Nm`` (external torque on the
        joint, N m, positive towards positive angle), ``stiffness_true_Nm_per_rad``.
    truth : dict
        The truth record (effect, parameters in SI units, effect size, noise, m, b...).
    """
    for attempt in range(20):
        try:
            data, truth = _simulate(spec, np.random.default_rng([spec.seed, attempt]))
        except _Infeasible:
            continue
        truth["attempt"] = attempt
        return data, json.loads(json.dumps(truth, default=lambda o: o.item()))
    raise RuntimeError(f"{spec.name}: could not size the effect in 20 attempts")


def suite(seed: int = 7100) -> list[TrialSpec]:
    """The standard 24-trial suite (12 independent-form, 6 same-form, 6 clean), 30 s each."""
    rows = []
    indep = ["lugre", "stribeck", "boucwen", "reflexact", "angledelay", "quaddampsat"]
    for i, form in enumerate(indep):
        rows.append(("independent", form, f"indep-{form}-elbow", "elbow",
                     ("cocontraction", "ramp")[i % 2], False, 2.5 if i == 0 else 0.0))
        rows.append(("independent", form, f"indep-{form}-ankle", "ankle",
                     ("gait", "constant")[i % 2], False, 3.5 if i == 3 else 0.0))
    rows += [("same", "coulomb", "same-coulomb-elbow", "elbow", "cocontraction", False, 0.0),
             ("same", "coulomb", "same-coulomb-ankle", "ankle", "gait", False, 0.0),
             ("same", "quaddamp", "same-quaddamp-ankle", "ankle", "constant", False, 0.0),
             ("same", "dahl", "same-dahl-elbow", "elbow", "ramp", False, 2.0),
             ("same", "torquedelay", "same-torquedelay-ankle", "ankle", "gait", False, 0.0),
             ("same", "reflex", "same-reflex-elbow", "elbow", "cocontraction", False, 0.0),
             ("clean", None, "clean-constant-elbow", "elbow", "constant", False, 0.0),
             ("clean", None, "clean-cocontraction-cubic-elbow", "elbow", "cocontraction",
              True, 0.0),
             ("clean", None, "clean-ramp-elbow", "elbow", "ramp", False, 0.0),
             ("clean", None, "clean-gait-ankle", "ankle", "gait", False, 0.0),
             ("clean", None, "clean-pause-elbow", "elbow", "cocontraction", False, 3.0),
             ("clean", None, "clean-vsa", "vsa", "vsa", False, 0.0)]
    return [TrialSpec(name=n, family=fam, form=f, joint=j, course=c, seed=seed + i,
                      cubic=cub, pause_s=p)
            for i, (fam, f, n, j, c, cub, p) in enumerate(rows)]


def write_trial(spec: TrialSpec, outdir: Path) -> dict:
    """Simulate ``spec`` and write ``outdir/<name>.csv`` and ``outdir/<name>.json``."""
    data, truth = make_trial(spec)
    joint = {"elbow": "elbow-like", "ankle": "ankle-like", "vsa": "antagonistic VSA"}
    with open(outdir / f"{spec.name}.csv", "w", encoding="utf-8", newline="") as fh:
        fh.write(f"# trial: {spec.name}\n# source: independent simulator\n"
                 f"# joint: {joint[spec.joint]}\n# fs_hz: {spec.fs_hz:g}\n")
        data.to_csv(fh, index=False, float_format="%.10g", lineterminator="\n")
    (outdir / f"{spec.name}.json").write_text(json.dumps(truth, indent=2) + "\n")
    return truth


def write_suites(seeds, root: Path) -> list[tuple[str, str]]:
    """Write the standard suite of each seed into ``root/<seed>/``; (folder, trial name) of every
    trial written, in order."""
    written = []
    for seed in seeds:
        folder = Path(root) / str(seed)
        folder.mkdir()
        for spec in suite(seed):
            write_trial(spec, folder)
            written.append((str(folder), spec.name))
    return written


def main(argv: list[str] | None = None) -> int:
    """CLI: write the standard suite into OUTDIR and print the effect-size table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--seed", type=int, default=7100)
    args = ap.parse_args(argv)
    args.outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"{'trial':34s} {'effect':18s} {'frac':>6s} {'eff/σf':>7s} {'k_med':>7s} {'s':>5s}")
    for spec in suite(args.seed):
        t1 = time.perf_counter()
        tr = write_trial(spec, args.outdir)
        print(f"{spec.name:34s} {str(tr['effect']):18s} {tr['effect_rms_fraction']:6.3f} "
              f"{tr['effect_to_noise']:7.2f} {tr['stiffness_median']:7.1f} "
              f"{time.perf_counter() - t1:5.1f}", flush=True)
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
