"""Human-limb scenarios: elbow and wrist (torque-driven), ankle (position-driven).

Values are typical of the joint-impedance literature (e.g. the Kearney lab ankle
recordings, see ``data/reklab-ankle/SOURCE.md`` in the repository); the elastic torque is
s = σ₀(t)·(Δ + ε·Δ³) with Δ = y − y₀, so σ = σ₀(t)·(1 + 3ε·Δ²).
"""

from __future__ import annotations

import math

import numpy as np

from .excitation import (draw_random_steps, fade_in, gate, gaussian_width, multisine,
                         random_phases, smooth_ramp, smoothed_steps)
from .plants import Joint, Setup

#: Raised-cosine fade at the start and at the edges of a pause, s.
FADE = 0.5
PAUSE_TAPER = 0.1


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _linear_joint(p, control) -> Joint:
    b, y0, eps = p["damping"], p["rest_angle"], p.get("stiffness_nonlinearity", 0.0)
    return Joint(
        inertia=p["inertia"],
        damping_torque=lambda v, lib: b * v,
        damping_slope=lambda v, lib: b + 0.0 * v,
        elastic_torque=lambda y, u, lib: u * ((y - y0) + eps * (y - y0) ** 3),
        stiffness=lambda y, u, lib: u * (1.0 + 3.0 * eps * (y - y0) ** 2),
        scalar_torque=(lambda y, v, u: b * v + u * (y - y0)) if eps == 0 else None)


def multisine_torque_scale(frequencies: np.ndarray, phases: np.ndarray, inertia: float,
                           damping: float, stiffness: float, angle_amplitude: float) -> float:
    """Per-component torque amplitude (N·m) of a flat multisine that moves a linear joint by
    ±``angle_amplitude`` rad (peak over one period of the steady state)."""
    w = 2.0 * math.pi * frequencies
    response = 1.0 / (stiffness - inertia * w**2 + 1j * damping * w)
    period = 1.0 / np.min(np.diff(np.sort(frequencies))) if frequencies.size > 1 else \
        1.0 / frequencies[0]
    t = np.linspace(0.0, period, int(40 * frequencies.max() * period) + 1)
    angle = multisine(t, frequencies, np.abs(response), phases=phases + np.angle(response))[0]
    return angle_amplitude / np.max(np.abs(angle))


def build_torque_driven_limb(p, rng) -> Setup:
    """A joint held by co-contraction and perturbed by a multisine torque (elbow, wrist).

    m·ÿ + b·ẏ + σ₀(t)·(Δ + ε·Δ³) = τ_ext, Δ = y − ``rest_angle``. The co-contraction
    stiffness σ₀ goes from ``stiffness_start`` to ``stiffness_end`` along a raised-cosine
    ramp between ``ramp_start_fraction`` and ``ramp_end_fraction`` of the trial. τ_ext is a
    multisine with flat amplitude on ``f_min``…``f_max`` Hz every ``frequency_step`` Hz,
    random phases from the trial's generator, scaled so that the linear steady-state angle
    would peak at ``angle_amplitude`` rad with the smaller of the two stiffnesses; it fades
    in over 0.5 s and is zero during [``pause_start``, ``pause_start`` + ``pause_duration``]
    (0.1 s raised-cosine edges; duration 0 = no pause).
    """
    duration = p["duration"]
    k0, k1 = p["stiffness_start"], p["stiffness_end"]
    if min(k0, k1) <= 0 or p["inertia"] <= 0:
        raise ValueError("stiffness and inertia must be positive")
    t0, t1 = p["ramp_start_fraction"] * duration, p["ramp_end_fraction"] * duration

    def control(t):
        return smooth_ramp(t, t0, t1, k0, k1)

    f_min, f_max, df = p["f_min"], p["f_max"], p["frequency_step"]
    if not 0 < f_min <= f_max or df <= 0:
        raise ValueError("need 0 < f_min <= f_max and frequency_step > 0")
    freqs = np.arange(f_min, f_max + 0.5 * df, df)
    phases = random_phases(rng, freqs.size)
    amp = multisine_torque_scale(freqs, phases, p["inertia"], p["damping"], min(k0, k1),
                                 p["angle_amplitude"])
    pause_start, pause_duration = p["pause_start"], p["pause_duration"]

    def external_torque(t):
        window = fade_in(t, FADE) * gate(t, pause_start, pause_duration, PAUSE_TAPER)
        return amp * multisine(t, freqs, 1.0, phases=phases)[0] * window

    eps = p["stiffness_nonlinearity"]
    reach = 3.0 * p["angle_amplitude"]
    return Setup(
        kind="rotational", joint=_linear_joint(p, control), control=control,
        external_torque=external_torque, initial_angle=p["rest_angle"],
        max_stiffness=max(k0, k1) * (1.0 + 3.0 * abs(eps) * reach**2),
        max_damping=p["damping"],
        metadata={"damping_law": "linear",
                  "excitation": f"multisine {f_min:g}-{f_max:g} Hz step {df:g} Hz, "
                                f"{freqs.size} components of {amp:.4g} N·m, random phases",
                  "stiffness_law": "s = sigma0(t)*(d + eps*d^3), d = y - rest_angle"})


def ankle_perturbation(p, rng) -> tuple:
    """The ankle platform's imposed angle: ``rest_angle`` + Gaussian-smoothed random steps.

    Returns
    -------
    trajectory : callable (t, derivatives) -> ndarray, shape (derivatives + 1, n), rad
    width : float
        sd of the Gaussian smoothing, s.
    """
    width = gaussian_width(p["cutoff"])
    times, levels = draw_random_steps(rng, p["duration"], p["perturbation_amplitude"],
                                      p["hold_min"], p["hold_max"])
    y0 = p["rest_angle"]

    def trajectory(t, derivatives):
        y = smoothed_steps(t, times, levels, width, derivatives)
        y[0] += y0
        return y

    return trajectory, width


def ankle_stiffness(p):
    """K(t) = ``stiffness``·(1 + ``stiffness_variation``·sin(2πt/``variation_period``)), N·m/rad.

    Returns
    -------
    callable (t) -> ndarray, shape (n,)
    """
    k, var, period = p["stiffness"], p["stiffness_variation"], p["variation_period"]
    if k <= 0 or abs(var) >= 1 or period <= 0:
        raise ValueError("need stiffness > 0, |stiffness_variation| < 1, variation_period > 0")

    def control(t):
        return k * (1.0 + var * np.sin(2.0 * math.pi * np.asarray(t) / period))

    return control


def build_ankle(p, rng) -> Setup:
    """Human ankle on a position-controlled platform (like the reklab recordings), position drive.

    The platform imposes y(t) = ``rest_angle`` + a random-level step sequence: levels
    uniform on ±``perturbation_amplitude`` (0.03 rad), held for a time uniform on
    [``hold_min``, ``hold_max``] (0.2–0.3 s), each jump smoothed by a Gaussian whose −3 dB
    frequency is ``cutoff`` (15 Hz; peak velocities ~1–3 rad/s as in the real data).
    Torque τ_ext = I·ÿ + B·ẏ + K(t)·(y − y₀) with I = 0.015 kg·m², B = 1 N·m·s/rad and
    K(t) = ``stiffness``·(1 + ``stiffness_variation``·sin(2πt/``variation_period``))
    (60 N·m/rad, constant by default). Recorded as the torque applied *to* the joint (the
    real data record the reaction torque, of opposite sign).
    """
    trajectory, width = ankle_perturbation(p, rng)
    control = ankle_stiffness(p)
    k, var = p["stiffness"], p["stiffness_variation"]
    return Setup(kind="rotational", joint=_linear_joint(p, control), control=control,
                 trajectory=trajectory, max_stiffness=k * (1 + abs(var)),
                 max_damping=p["damping"],
                 metadata={"damping_law": "linear",
                           "excitation": "random-level steps, Gaussian-smoothed "
                                         f"(sd {_fmt(width)} s), position drive"})


_LIMB = {"fs": 1000.0, "duration": 30.0, "stiffness_nonlinearity": 0.0, "rest_angle": 0.0,
         "ramp_start_fraction": 0.25, "ramp_end_fraction": 0.75, "f_min": 0.5, "f_max": 8.0,
         "frequency_step": 0.1, "pause_start": 0.0, "pause_duration": 0.0}

#: (name, kind, description, defaults, build)
LIMBS = [
    ("elbow", "rotational",
     "human elbow, torque-driven multisine 0.5-8 Hz, co-contraction stiffness 6 -> 30 N·m/rad",
     {**_LIMB, "torque_noise": 0.01, "encoder_counts": 8000.0, "inertia": 0.06,
      "damping": 0.45, "stiffness_start": 6.0, "stiffness_end": 30.0,
      "angle_amplitude": 0.045},
     build_torque_driven_limb),
    ("ankle", "rotational",
     "human ankle on a position-controlled platform, random steps ±0.03 rad, K = 60 N·m/rad",
     {"fs": 1000.0, "duration": 60.0, "torque_noise": 0.05, "encoder_counts": 0.0,
      "inertia": 0.015, "damping": 1.0, "stiffness": 60.0, "stiffness_variation": 0.0,
      "variation_period": 20.0, "rest_angle": 0.0, "perturbation_amplitude": 0.03,
      "hold_min": 0.2, "hold_max": 0.3, "cutoff": 15.0},
     build_ankle),
    ("wrist", "rotational",
     "human wrist, torque-driven multisine 0.5-8 Hz, stiffness 1 -> 4 N·m/rad, 500 Hz",
     {**_LIMB, "fs": 500.0, "torque_noise": 0.002, "encoder_counts": 4096.0,
      "inertia": 0.004, "damping": 0.05, "stiffness_start": 1.0, "stiffness_end": 4.0,
      "angle_amplitude": 0.05},
     build_torque_driven_limb),
]
