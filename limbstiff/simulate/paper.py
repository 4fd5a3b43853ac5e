"""Scenarios of Grioli & Bicchi (RSS 2010): the exponential spring and the antagonistic links.

Each ``build_*`` takes the full parameter dict (defaults merged with the user's) and the
trial's random generator, and returns a :class:`~limbstiff.simulate.plants.Setup`. The
paper scenarios have no random part and no noise by default.
"""

from __future__ import annotations

import math

import numpy as np

from .excitation import chirp, gate, saturated_ramp, sinusoid
from .plants import Joint, Setup

#: The three exponential springs of Fig. 6: s(y) = a·e^(b·y), y in cm, s in N.
EXP_SPRINGS = {1: (2.7 * math.exp(-2.0), 1.0), 2: (8.1 * math.exp(-6.0), 3.0),
               3: (13.5 * math.exp(-10.0), 5.0)}

_NO_DAMPING = dict(damping_torque=lambda v, lib: 0.0 * v, damping_slope=lambda v, lib: 0.0 * v)


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _choice(p, key, allowed):
    value = p[key]
    if value not in allowed:
        raise ValueError(f"parameter '{key}' must be one of {sorted(allowed)}, got {value:g}")
    return int(value)


def build_exp_spring(p, rng) -> Setup:
    """Sec. IV-A, Fig. 6: a massless exponential spring under a prescribed chirp deformation.

    s(y) = a·e^(b·y) with y in cm in the paper; in SI s(y) = a·e^(100·b·y) N with y in m and
    σ(y) = 100·a·b·e^(100·b·y) N/m. ``spring`` selects (a, b) = (2.7e⁻², 1), (8.1e⁻⁶, 3) or
    (13.5e⁻¹⁰, 5) (cm⁻¹ for b); all three give s = 2.7·b N at y = 2 cm. The deformation is
    y(t) = c − h·cos φ(t) with c, h the centre and half-range of [position_min,
    position_max] (default [0.25, 2.25] cm) and φ a chirp whose frequency sweeps from
    ``f_start`` = 0.1 Hz to ``f_end`` = 10 Hz over the trial, logarithmically (equal time per
    octave; ``logarithmic_sweep`` = 0 for a linear sweep). The trial starts at rest at
    ``position_min``. Mass and damping are zero, so the external force equals the spring
    force and both are recorded (``torque`` and ``elastic_torque``).
    """
    a, b_cm = EXP_SPRINGS[_choice(p, "spring", {1, 2, 3})]
    b = 100.0 * b_cm
    lo, hi = p["position_min"], p["position_max"]
    if not hi > lo:
        raise ValueError("parameter 'position_max' must exceed 'position_min'")
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    method = "logarithmic" if _choice(p, "logarithmic_sweep", {0, 1}) else "linear"
    f0, f1, sweep = p["f_start"], p["f_end"], p["duration"]

    def trajectory(t, derivatives):
        y = half * chirp(t, f0, f1, sweep, method=method, phase=-0.5 * math.pi,
                         derivatives=derivatives)
        y[0] += centre
        return y

    joint = Joint(inertia=0.0, elastic_torque=lambda y, u, lib: a * lib.exp(b * y),
                  stiffness=lambda y, u, lib: a * b * lib.exp(b * y), **_NO_DAMPING)
    return Setup(kind="translational", joint=joint, control=lambda t: np.zeros_like(t),
                 trajectory=trajectory, record_elastic=True, metadata={
                     "spring_law": "s = a*exp(b*y)", "spring_a_N": _fmt(a),
                     "spring_b_per_m": _fmt(b), "sweep": method, "damping_law": "none"})


def _link(p, elastic, stiffness, control, *, quadratic: bool, torque_gate=None,
          notes=None) -> Setup:
    """The link of Fig. 3 under τ_e = A·sin(ωt) (optionally gated), torque drive."""
    inertia, amp, omega = p["inertia"], p["torque_amplitude"], p["omega"]
    if quadratic:
        beta = p["beta"]
        damping = dict(damping_torque=lambda v, lib: beta * v * abs(v),
                       damping_slope=lambda v, lib: 2.0 * beta * abs(v))
        law, coefficient = "quadratic", beta
    else:
        c = p["damping"]
        damping = dict(damping_torque=lambda v, lib: c * v,
                       damping_slope=lambda v, lib: c + 0.0 * v)
        law, coefficient = "linear", c
    joint = Joint(inertia=inertia, elastic_torque=elastic, stiffness=stiffness, **damping)
    grid = np.linspace(0.0, p["duration"], 2001)
    sigma = stiffness(0.0, control(grid), np)
    if np.min(sigma) <= 0:
        raise ValueError("these parameters make the link unstable (stiffness <= 0 at θ = 0)")

    def external_torque(t):
        tau = sinusoid(t, amp, omega)[0]
        return tau * torque_gate(t) if torque_gate is not None else tau

    # Start on the linearised steady-state response θ = Im(A·H·e^(iωt)), H = 1/(σ − Iω² + icω)
    # (c = 0 for the quadratic damping), so that there is no start-up transient or beat.
    y0 = v0 = 0.0
    detuning = float(sigma[0]) - inertia * omega**2
    if not quadratic or abs(detuning) > 0.2 * float(sigma[0]):
        response = amp / complex(detuning, 0.0 if quadratic else p["damping"] * omega)
        y0, v0 = response.imag, omega * response.real
    meta = {"damping_law": law, "damping_coefficient": _fmt(coefficient),
            "excitation": f"torque {amp:g}*sin({omega:g} t) N·m"}
    meta.update(notes or {})
    return Setup(kind="rotational", joint=joint, control=control,
                 external_torque=external_torque, initial_angle=y0, initial_velocity=v0,
                 max_stiffness=float(np.max(np.abs(sigma))) + p["mgl"],
                 max_damping=2.0 * coefficient if quadratic else coefficient,
                 record_elastic=bool(_choice(p, "include_elastic", {0, 1})), metadata=meta)


def _ramped(p, name: str):
    """A link's control: ``p[name + "_start"]`` until ``ramp_start`` s, then linearly to
    ``p[name + "_end"]`` at ``ramp_end`` s, held after."""
    def control(t):
        return saturated_ramp(t, p["ramp_start"], p["ramp_end"], p[f"{name}_start"], p[f"{name}_end"])
    return control


def build_vsa_hogan(p, rng) -> Setup:
    """Sec. II example (Fig. 3, actuator model (3)) and Sec. IV-B / Fig. 7a.

    I·θ̈ + β·θ̇|θ̇| − τ_b + τ_t − mgl·sin θ = τ_e with τ_b = (τmax − α·θ_b)·u, τ_t =
    (τmax − α·θ_t)·u, θ_b = π/2 + θ, θ_t = π/2 − θ, u_b = u_t = u; I = 0.05 kg·m²,
    mgl = 0.1 N·m, β = 1 N·m·s²/rad², α = 1 N·m/rad, τmax = 2 N·m (Fig. 4). Elastic torque
    s = −τ_b + τ_t − mgl·sin θ = 2αuθ − mgl·sin θ, stiffness σ = 2αu − mgl·cos θ (with
    gravity), generalized damping 2β|θ̇|. τ_e = 0.02·sin(5t) N·m.

    Saturated ramp (our choice; the paper gives none for Fig. 7): u = 0.25 until 5 s, linear
    to 0.9 at 20 s, then held, so σ goes 0.4 → 1.7 N·m/rad, always positive, crossing the
    resonance Iω² = 1.25 N·m/rad near 15 s where only the quadratic damping limits the
    motion. The link starts on its steady-state response (θ̇(0) = ωA/(σ(0) − Iω²)). The
    resulting motion (30 s default) has amplitude 0.021 rad at the start, 0.030 rad around
    the resonance and 0.028 rad at the end (|θ| ≤ 0.031 rad, |θ̇| ≤ 0.16 rad/s) — larger
    than the paper's quoted ±0.01 rad / 0.05 rad/s, which these model values cannot give
    (u ≤ 1 keeps σ ≤ 1.9 N·m/rad, and 0.02/|σ − Iω²| ≥ 0.01 rad for every such σ).
    ``include_elastic`` = 1 records s as ``elastic_torque`` (direct variant).
    """
    alpha, tmax, mgl = p["alpha"], p["tau_max"], p["mgl"]
    half_pi = 0.5 * math.pi

    def elastic(y, u, lib):
        tau_b = (tmax - alpha * (half_pi + y)) * u
        tau_t = (tmax - alpha * (half_pi - y)) * u
        return -tau_b + tau_t - mgl * lib.sin(y)

    def stiffness(y, u, lib):
        return 2.0 * alpha * u - mgl * lib.cos(y)

    return _link(p, elastic, stiffness, _ramped(p, "activation"), quadratic=True,
                 notes={"actuator_model": "Hogan (3): tau = (tau_max - alpha*theta)*u",
                        "control": "activation u_b = u_t"})


def build_vsa_feldman(p, rng) -> Setup:
    """Sec. II example with actuator model (4) (Fig. 5) and Sec. IV-B / Fig. 7b.

    Same link as ``paper-vsa-hogan`` with τ_b = −α(θ_b − λ)², τ_t = −α(θ_t − λ)², α = 0.3,
    rest lengths λ_b = λ_t = λ decreasing linearly from π/3 at 1 s to 0 at 15 s, then held.
    s = α(π/2 + θ − λ)² − α(π/2 − θ − λ)² − mgl·sin θ and σ = 2α(π − 2λ) − mgl·cos θ, which
    goes 0.53 → 1.78 N·m/rad (crossing the resonance 1.25 N·m/rad near 9 s).
    τ_e = 0.02·sin(5t) N·m. The motion (30 s default) has amplitude 0.022 rad at the start,
    0.030 rad around the resonance and 0.026 rad at the end (|θ| ≤ 0.031 rad, |θ̇| ≤ 0.16
    rad/s).
    """
    alpha, mgl = p["alpha"], p["mgl"]
    half_pi = 0.5 * math.pi

    def elastic(y, lam, lib):
        return (alpha * (half_pi + y - lam) ** 2 - alpha * (half_pi - y - lam) ** 2
                - mgl * lib.sin(y))

    def stiffness(y, lam, lib):
        return 2.0 * alpha * (math.pi - 2.0 * lam) - mgl * lib.cos(y)

    return _link(p, elastic, stiffness, _ramped(p, "rest_angle"), quadratic=True,
                 notes={"actuator_model": "Feldman (4): tau = -alpha*(theta - lambda)^2",
                        "control": "rest angle lambda_b = lambda_t, rad"})


def build_vsa_exp(p, rng) -> Setup:
    """Sec. IV-B, Fig. 9: the link on two antagonistic exponential springs.

    Tendon forces F = a·e^(b·x) on elongations x = x₀ ± rθ (moment arm r), so
    s = r·a·(e^(b(x₀+rθ)) − e^(b(x₀−rθ))) − mgl·sin θ and
    σ = r²·a·b·(e^(b(x₀+rθ)) + e^(b(x₀−rθ))) − mgl·cos θ. The pretension x₀ rises linearly
    from 2 cm to 4 cm over the trial, so the spring stiffness 2r²ab·e^(b·x₀) grows
    exponentially, 0.59 → 4.4 N·m/rad (σ 0.49 → 4.3 N·m/rad with gravity). Linear damping
    0.3 N·m·s/rad (time constant 2I/b = 0.33 s: free motion dies out in ~1.5 s). τ_e =
    0.02·sin(5t) N·m except between 10 s and 20 s where it is zero. The link starts on its
    linear steady-state response; the motion stays within ±0.013 rad (|θ̇| ≤ 0.07 rad/s),
    decays below 1e-3 rad within 1.5 s of the pause and resumes at ~0.011 rad, shrinking
    to 0.006 rad as the stiffness grows.
    """
    r, a, b, mgl = p["moment_arm"], p["spring_force"], p["spring_rate"], p["mgl"]

    def elastic(y, x0, lib):
        return r * a * (lib.exp(b * (x0 + r * y)) - lib.exp(b * (x0 - r * y))) - mgl * lib.sin(y)

    def stiffness(y, x0, lib):
        return (r * r * a * b * (lib.exp(b * (x0 + r * y)) + lib.exp(b * (x0 - r * y)))
                - mgl * lib.cos(y))

    def control(t):
        return saturated_ramp(t, 0.0, p["duration"], p["pretension_start"], p["pretension_end"])

    def torque_gate(t):
        return gate(t, p["pause_start"], p["pause_duration"])

    return _link(p, elastic, stiffness, control, quadratic=False, torque_gate=torque_gate,
                 notes={"actuator_model": "exponential springs F = a*exp(b*x)",
                        "control": "pretension x0, m"})


_COMMON = {"fs": 1000.0, "torque_noise": 0.0, "encoder_counts": 0.0}
_LINK = {**_COMMON, "duration": 30.0, "inertia": 0.05, "mgl": 0.1, "torque_amplitude": 0.02,
         "omega": 5.0, "include_elastic": 0.0}

#: (name, kind, description, defaults, build)
PAPER = [
    ("paper-exp-spring", "translational",
     "Sec. IV-A / Fig. 6: massless exponential spring, chirp deformation 0.25-2.25 cm",
     {"fs": 1000.0, "duration": 20.0, "torque_noise": 0.0, "position_resolution": 0.0,
      "spring": 1.0, "position_min": 0.0025, "position_max": 0.0225, "f_start": 0.1,
      "f_end": 10.0, "logarithmic_sweep": 1.0},
     build_exp_spring),
    ("paper-vsa-hogan", "rotational",
     "Sec. II / Fig. 3-4, Fig. 7a: link with Hogan antagonistic actuators, activation ramp",
     {**_LINK, "beta": 1.0, "alpha": 1.0, "tau_max": 2.0, "activation_start": 0.25,
      "activation_end": 0.9, "ramp_start": 5.0, "ramp_end": 20.0},
     build_vsa_hogan),
    ("paper-vsa-feldman", "rotational",
     "Sec. II / Fig. 5, Fig. 7b: link with Feldman (lambda-model) actuators, rest-angle ramp",
     {**_LINK, "beta": 1.0, "alpha": 0.3, "rest_angle_start": math.pi / 3,
      "rest_angle_end": 0.0, "ramp_start": 1.0, "ramp_end": 15.0},
     build_vsa_feldman),
    ("paper-vsa-exp", "rotational",
     "Sec. IV-B / Fig. 9: link on antagonistic exponential springs, pretension ramp, pause",
     {**_LINK, "damping": 0.3, "moment_arm": 0.02, "spring_force": 1.0, "spring_rate": 100.0,
      "pretension_start": 0.02, "pretension_end": 0.04, "pause_start": 10.0,
      "pause_duration": 10.0},
     build_vsa_exp),
]
