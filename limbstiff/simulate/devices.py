"""Ankle set-ups where the device shapes the recording: a compliant coupling, a moving platform.

Two failure modes of real recordings (issue 12) that the one-body model
f = I·ÿ + B·ẏ + σ·y does not contain:

* ``ankle-coupled`` — the footplate is joined to the foot through skin, shoe and straps (a
  spring k_c and a damper b_c); the angle is measured at the device, the torque at the
  device's sensor, so the joint is seen through the coupling (:func:`build_ankle_coupled`);
* ``ankle-platform`` — pseudo-random steps about an operating point that moves slowly; the
  angle channel records only the steps, the torque channel everything
  (:func:`build_ankle_platform`).

The coupled plant has two bodies; with the device's position imposed by an ideal position
loop, its 4-state system (θ_d, θ̇_d, θ_l, θ̇_l) reduces to the limb's 2 states driven by the
analytic θ_d(t), which the RK4 of :mod:`.plants` integrates (:func:`coupled_plant`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .excitation import draw_binary_steps, gaussian_width, sinusoid, smoothed_steps
from .limbs import _linear_joint, ankle_perturbation, ankle_stiffness
from .plants import DynamicsTerm, Joint, Setup, _torque_drive, unrecorded_angle
from .truth import CoupledLimb, TrueSignals


def _fmt(x: float) -> str:
    return f"{x:.6g}"


# --- ankle-coupled ----------------------------------------------------------------------------

def coupling_stiffness(limb_inertia: float, stiffness: float, frequency: float) -> float:
    """k_c = I_l·(2π·f_c)² − K (N·m/rad): the coupling that puts the limb's resonance on the
    held device at ``frequency`` f_c (Hz), for limb inertia I_l (kg·m²) and stiffness K
    (N·m/rad)."""
    return limb_inertia * (2.0 * math.pi * frequency) ** 2 - stiffness


def coupling_mode(limb_inertia: float, limb_damping: float, stiffness: float,
                  coupling_stiffness: float, coupling_damping: float) -> tuple[float, float]:
    """Natural frequency (Hz) and damping ratio of the limb on the coupling, device held.

    The eigenvalues λ of the linearised limb equation I_l·θ̈_l + (B_l + b_c)·θ̇_l +
    (K + k_c)·θ_l = 0 (SI units as in :func:`build_ankle_coupled`): f_n = |λ|/2π,
    ζ = −Re λ/|λ|.
    """
    a = np.array([[0.0, 1.0],
                  [-(stiffness + coupling_stiffness) / limb_inertia,
                   -(limb_damping + coupling_damping) / limb_inertia]])
    lam = np.linalg.eigvals(a)[0]
    return float(abs(lam) / (2.0 * math.pi)), float(-lam.real / abs(lam))


def one_body_equivalent(device_inertia: float, limb_inertia: float, limb_damping: float,
                        stiffness: float, coupling_stiffness: float,
                        coupling_damping: float) -> dict[str, float]:
    """The one-body model that the coupled ankle looks like at low frequency.

    The impedance f/θ_d (device held) is Z(s) = I_d·s² + (k_c + b_c·s)(I_l·s² + B_l·s + K) /
    (I_l·s² + (B_l + b_c)·s + K + k_c); its expansion Z ≈ K' + B'·s + I'·s² about s = 0 gives

    K' = K·k_c/(K + k_c) (springs in series), B' = (B_l·k_c² + b_c·K²)/(K + k_c)²,
    I' = I_d + I_l·k_c²/(K + k_c)² − (B_l·k_c − b_c·K)²/(K + k_c)³.

    Returns
    -------
    dict
        ``stiffness`` K' (N·m/rad), ``damping`` B' (N·m·s/rad), ``inertia`` I' (kg·m²).
    """
    k, kc, bc, bl = stiffness, coupling_stiffness, coupling_damping, limb_damping
    total = k + kc
    return {"stiffness": k * kc / total,
            "damping": (bl * kc**2 + bc * k**2) / total**2,
            "inertia": (device_inertia + limb_inertia * (kc / total) ** 2
                        - (bl * kc - bc * k) ** 2 / total**3)}


def coupled_plant(coupling_stiffness: float, coupling_damping: float, device_inertia: float,
                  rest_angle: float):
    """The plant of ``ankle-coupled``: ``plant(setup, term, t, fs) -> TrueSignals`` (see ``run``).

    k_c (N·m/rad), b_c (N·m·s/rad), I_d (kg·m²) and y₀ (rad) as in
    :func:`build_ankle_coupled`.

    The limb I_l·θ̈_l + B_l·θ̇_l + K(t)·(θ_l − y₀) + e = k_c·(θ_d − θ_l) + b_c·(θ̇_d − θ̇_l) is
    integrated by the RK4 of :mod:`.plants` under the imposed θ_d(t) = ``setup.trajectory``
    (the coupling enters as part of the effect torque), starting at rest in static
    equilibrium. The internal step obeys h ≤ 1/(20·f_n) with f_n = √((K_max + k_c)/I_l)/2π
    ≥ f_c, the coupling resonance. An effect acts on the limb (its angle, velocity, inertia,
    damping); ``angle``…``jerk`` of the truth are the device's, its ``limb`` the limb's.
    """
    kc, bc, inertia_d, y0 = coupling_stiffness, coupling_damping, device_inertia, rest_angle

    def plant(setup: Setup, term: DynamicsTerm, t: np.ndarray, fs: float) -> TrueSignals:
        joint, drive = setup.joint, setup.trajectory
        m = joint.inertia * term.inertia_scale
        effect = term.torque
        if effect is None:
            def torque(y, v, z, vd, lib):
                return kc * y + bc * v
        else:
            def torque(y, v, z, vd, lib):
                return kc * y + bc * v + effect(y, v, z, vd, lib)
        def coupling_drive(tt):              # the coupling's torque from the device's side
            yd, vd = drive(tt, 1)
            return kc * yd + bc * vd

        y_start = drive(t[:1], 0)[0, 0]
        u_start = float(np.ravel(setup.control(t[:1]))[0])
        limb_start = y0 + kc * (y_start - y0) / (u_start + kc)
        limb = replace(setup, plant=None, trajectory=None, initial_angle=limb_start,
                       external_torque=coupling_drive)
        motion = _torque_drive(limb, replace(term, torque=torque,
                                             max_stiffness=term.max_stiffness + kc,
                                             max_damping=term.max_damping + bc), t, fs, m)
        return _coupled_signals(setup, term, t, m, motion, (kc, bc, inertia_d))

    return plant


def _coupled_signals(setup: Setup, term: DynamicsTerm, t: np.ndarray, m: float, motion,
                     coupling: tuple) -> TrueSignals:
    """The true signals of :func:`coupled_plant` from the limb's motion (``_Motion``): the
    device's motion, the torque at its sensor, the limb's stiffness and damping."""
    kc, bc, inertia_d = coupling
    joint, n = setup.joint, len(t)
    yd, vd, ad, jd = setup.trajectory(t, 3)
    yl, vl = motion.angle, motion.velocity
    u = np.broadcast_to(np.asarray(setup.control(t), dtype=float), t.shape).copy()
    effect = (term.torque(yl, vl, motion.state, motion.delayed_velocity, np)
              if term.torque is not None else np.zeros(n))
    coupling_torque = kc * (yd - yl) + bc * (vd - vl)
    return TrueSignals(
        time=t, angle=yd, velocity=vd, acceleration=ad, jerk=jd, control=u,
        elastic_torque=np.broadcast_to(joint.elastic_torque(yl, u, np), t.shape).astype(float),
        stiffness=np.broadcast_to(joint.stiffness(yl, u, np), t.shape).astype(float),
        generalized_damping=np.broadcast_to(term.damping_scale * joint.damping_slope(vl, np),
                                            t.shape).astype(float),
        damping_torque=term.damping_scale * joint.damping_torque(vl, np),
        effect_torque=np.broadcast_to(effect, t.shape).astype(float),
        external_torque=inertia_d * ad + coupling_torque, unrecorded_angle=unrecorded_angle(setup, t),
        inertia=m, internal_step=motion.internal_step, delay=motion.delay,
        limb=CoupledLimb(angle=yl, velocity=vl, acceleration=motion.acceleration, jerk=motion.jerk,
                         coupling_torque=coupling_torque, device_inertia=inertia_d))


def _checked_coupling(p) -> float:
    """k_c (N·m/rad) of the ``ankle-coupled`` parameters, which it checks."""
    il, fc, k = p["limb_inertia"], p["coupling_frequency"], p["stiffness"]
    if (il <= 0 or fc <= 0 or
            min(p["device_inertia"], p["limb_damping"], p["coupling_damping"]) < 0):
        raise ValueError("need limb_inertia > 0, coupling_frequency > 0 and device_inertia, "
                         "limb_damping, coupling_damping >= 0")
    kc = coupling_stiffness(il, k, fc)
    if kc <= 0:
        raise ValueError(f"coupling_frequency {fc:g} Hz is below the limb's own resonance "
                         f"{math.sqrt(k / il) / (2 * math.pi):.3g} Hz: no positive coupling "
                         "stiffness gives it")
    return kc


def build_ankle_coupled(p, rng) -> Setup:
    """The ankle seen through a compliant coupling (skin, shoe, straps) to the device.

    Two bodies. The device — the footplate and what lies between it and the torque sensor,
    inertia I_d = ``device_inertia`` (0.005 kg·m²) — follows the commanded angle exactly (an
    ideal, infinitely stiff position loop): θ_d(t) = ``rest_angle`` + the ``ankle``
    scenario's Gaussian-smoothed random steps (``perturbation_amplitude``, ``hold_min``,
    ``hold_max``, ``cutoff``). The foot (limb), I_l = ``limb_inertia`` (0.01 kg·m²),
    B_l = ``limb_damping`` (1 N·m·s/rad), K(t) as in ``ankle`` (``stiffness`` 60 N·m/rad,
    ``stiffness_variation``, ``variation_period``), is joined to it by a spring k_c and a
    damper b_c = ``coupling_damping`` (0.3 N·m·s/rad):

        I_l·θ̈_l + B_l·θ̇_l + K(t)·(θ_l − y₀) = τ_c,  τ_c = k_c·(θ_d − θ_l) + b_c·(θ̇_d − θ̇_l).

    k_c = I_l·(2π·f_c)² − K with f_c = ``coupling_frequency`` (35 Hz, for 20–60 Hz;
    k_c = 424 N·m/rad by default): the undamped resonance of the limb on the held device,
    √((K + k_c)/I_l)/2π, is f_c at the nominal K (ζ = (B_l + b_c)/(2·I_l·2πf_c) = 0.30).
    Recorded: the angle at the device, θ_d (``encoder_counts`` as ``ankle``: none), and the
    torque of the device's sensor, which sits between the actuator and the footplate and so
    measures the torque applied to the footplate side, f = I_d·θ̈_d + τ_c, with the
    ``ankle``'s torque noise (0.05 N·m). ``stiffness_true`` is the limb's K(t).

    Expected bias of a one-body analysis (f = I·θ̈_d + B·θ̇_d + K·θ_d): far below f_c the
    limb follows the device with θ_l − y₀ ≈ k_c/(K + k_c)·(θ_d − y₀) (0.88 of the device's
    motion by default) and the set-up looks like one body with (:func:`one_body_equivalent`)
    K' = K·k_c/(K + k_c) = K·(1 − K/(I_l·(2πf_c)²)) — the springs in series: 52.6 instead
    of 60 N·m/rad (−12 %) at 35 Hz, −38 % at 20 Hz, −4 % at 60 Hz —, B' = (B_l·k_c² +
    b_c·K²)/(K + k_c)² = 0.77 N·m·s/rad and I' ≈ I_d + I_l·(k_c/(K + k_c))² − (B_l·k_c −
    b_c·K)²/(K + k_c)³ = 0.011 kg·m² (≈ I_d + I_l below f_c when k_c ≫ K). Near and above
    f_c the impedance f/θ_d has a resonance that no one-body model fits (apparent stiffness
    falling, then negative; the excitation's 15 Hz cutoff still leaves −16 dB at 35 Hz).
    Effects act on the limb (``inertia_error`` and ``damping_error`` scale I_l and B_l).
    """
    il, bl, idev = p["limb_inertia"], p["limb_damping"], p["device_inertia"]
    k, bc = p["stiffness"], p["coupling_damping"]
    kc = _checked_coupling(p)
    trajectory, width = ankle_perturbation(p, rng)
    control = ankle_stiffness(p)
    limb = {"inertia": il, "damping": bl, "rest_angle": p["rest_angle"]}
    fn, zeta = coupling_mode(il, bl, k, kc, bc)
    equivalent = one_body_equivalent(idev, il, bl, k, kc, bc)
    return Setup(
        kind="rotational", joint=_linear_joint(limb, control), control=control,
        trajectory=trajectory, max_stiffness=k * (1 + abs(p["stiffness_variation"])),
        max_damping=bl, plant=coupled_plant(kc, bc, idev, p["rest_angle"]),
        metadata={"damping_law": "linear", "damping_coefficient": _fmt(bl),
                  "excitation": "random-level steps, Gaussian-smoothed "
                                f"(sd {_fmt(width)} s), device position imposed",
                  "angle_measured_at": "device (footplate)",
                  "torque_measured_as": "torque on the footplate side: I_d*acc_d + coupling",
                  "coupling_stiffness": _fmt(kc), "coupling_damping": _fmt(bc),
                  "coupling_resonance_hz": _fmt(fn), "coupling_damping_ratio": _fmt(zeta),
                  "device_inertia": _fmt(idev),
                  **{f"one_body_{key}": _fmt(v) for key, v in equivalent.items()}})


# --- ankle-platform ---------------------------------------------------------------------------

def operating_point_stiffness(p):
    """The platform ankle's stiffness K(φ) and slow elastic torque s₀(φ) at operating point φ.

    K(φ) = K_lo + (K_hi − K_lo)·g(φ), g(φ) = (e^(β(φ−φ_lo)) − 1)/(e^(β(φ_hi−φ_lo)) − 1)
    (g = (φ − φ_lo)/(φ_hi − φ_lo) for β = 0), rising from K_lo = ``stiffness_min`` at
    φ_lo = ``operating_angle_min`` to K_hi = ``stiffness_max`` at φ_hi =
    ``operating_angle_max``; β = ``stiffness_curvature`` (1/rad). s₀(φ) = ∫ K from
    ``rest_angle`` to φ, in closed form.

    Returns
    -------
    stiffness, static_torque : callable (φ) -> ndarray
        K (N·m/rad) and s₀ (N·m) of φ (rad).
    """
    lo, hi = p["operating_angle_min"], p["operating_angle_max"]
    k_lo, k_hi, beta, rest = (p["stiffness_min"], p["stiffness_max"],
                              p["stiffness_curvature"], p["rest_angle"])
    if not hi > lo or k_lo <= 0 or k_hi <= 0:
        raise ValueError("need operating_angle_max > operating_angle_min and positive "
                         "stiffness_min, stiffness_max")
    span = hi - lo

    def shape(phi):                          # g(φ) and its antiderivative G(φ)
        x = np.asarray(phi, dtype=float) - lo
        if beta == 0:
            return x / span, 0.5 * x * x / span
        scale = math.expm1(beta * span)
        return np.expm1(beta * x) / scale, (np.expm1(beta * x) / beta - x) / scale

    def stiffness(phi):
        return k_lo + (k_hi - k_lo) * shape(phi)[0]

    def static_torque(phi):
        return (k_lo * (np.asarray(phi, dtype=float) - rest)
                + (k_hi - k_lo) * (shape(phi)[1] - shape(rest)[1]))

    return stiffness, static_torque


def _operating_point(p):
    """φ(t) = c − h·cos(2πt/T) between the operating angles, starting at the lower one.

    Returns callable (t, derivatives) -> ndarray, shape (derivatives + 1, n), rad.
    """
    lo, hi, period = p["operating_angle_min"], p["operating_angle_max"], p["operating_period"]
    if period <= 0:
        raise ValueError("parameter 'operating_period' must be positive")
    centre, half, omega = 0.5 * (lo + hi), 0.5 * (hi - lo), 2.0 * math.pi / period

    def phi(t, derivatives):
        out = sinusoid(t, -half, omega, 0.5 * math.pi, derivatives)
        out[0] += centre
        return out

    return phi


def _platform_joint(p, stiffness, static_torque) -> Joint:
    """The joint linear about its operating point u = φ: s = s₀(φ) + K(φ)·(y − φ)."""
    b = p["damping"]
    return Joint(
        inertia=p["inertia"],
        damping_torque=lambda v, lib: b * v,
        damping_slope=lambda v, lib: b + 0.0 * v,
        elastic_torque=lambda y, u, lib: static_torque(u) + stiffness(u) * (y - u),
        stiffness=lambda y, u, lib: stiffness(u) + 0.0 * y)


def _platform_trajectory(p, rng, phi) -> tuple:
    """θ(t) = φ(t) + q(t): the operating point ``phi`` plus the smoothed binary steps.

    Returns the trajectory, callable (t, derivatives) -> ndarray (derivatives + 1, n), rad,
    and the smoothing's sd, s.
    """
    times, levels = draw_binary_steps(rng, p["duration"], p["step_amplitude"],
                                      p["hold_min"], p["hold_max"])
    width = gaussian_width(p["cutoff"])

    def trajectory(t, derivatives):
        return phi(t, derivatives) + smoothed_steps(t, times, levels, width, derivatives)

    return trajectory, width


def build_ankle_platform(p, rng) -> Setup:
    """An ankle on a perturbation platform whose operating point moves slowly.

    The platform imposes θ(t) = φ(t) + q(t). The operating point φ(t) = c − h·cos(2πt/T)
    sweeps [``operating_angle_min``, ``operating_angle_max``] (−0.4…+0.2 rad) with period T =
    ``operating_period`` (40 s; it starts at the lower end). The perturbation q(t) is PRBS-like:
    levels ±``step_amplitude`` (0.06 rad, so every jump is 0.12 rad), alternating, each held
    for a time uniform on [``hold_min``, ``hold_max``] (50–200 ms), jumps smoothed by the
    position loop, modelled as a Gaussian with −3 dB frequency ``cutoff`` (15 Hz). The joint,
    I = ``inertia`` (0.015 kg·m²), B = ``damping`` (1 N·m·s/rad), is linear in the
    perturbation about its operating point (a parameter-varying model):

        τ = I·θ̈ + B·θ̇ + s₀(φ) + K(φ)·(θ − φ),

    with K(φ) rising smoothly and monotonically from ``stiffness_min`` (15 N·m/rad) at −0.4
    rad to ``stiffness_max`` (85 N·m/rad) at +0.2 rad, convex by ``stiffness_curvature`` (3
    /rad; 0 = linear in φ), and s₀(φ) = ∫ K dφ from ``rest_angle`` (0) the slow elastic
    torque: −11.2 N·m at −0.4 rad, +12.8 N·m at +0.2 rad (:func:`operating_point_stiffness`).
    ``stiffness_true`` = ∂τ/∂θ = K(φ(t)): it follows the operating point.

    Recorded: the angle is only the perturbation q = θ − φ (a platform that re-zeros its
    encoder at the operating point, or records its perturbation command; encoder as
    ``ankle``: none); the torque is all of τ, with the slow s₀(φ(t)) and I·φ̈ + B·φ̇, and the
    ``ankle``'s noise (0.05 N·m); ``reaction_torque`` = 1 records −τ (the sensor's reaction
    torque, as in the real data). Effects act on the true angle θ; they are sized on the
    recorded angle and the whole torque.

    Expected bias of a one-body analysis on (q, τ): the slow torque s₀(φ(t)), 24 N·m peak to
    peak against K·0.12 ≈ 2–10 N·m per step, has no counterpart in the angle, which has no
    slow component. Unless the torque is high-passed well above 1/T = 0.025 Hz (or a slowly
    varying torque offset is fitted), it enters as an offset of up to ~±12 N·m: a fitted σ̂
    must explain it with q = ±0.06 rad, i.e. errors of up to s₀/0.06 ≈ ±200 N·m/rad of
    opposite sign on the two levels, and a constant fit is pulled towards whatever mean
    q·s₀ happens to have. With the slow part s₀(φ) + I·φ̈ + B·φ̇ removed (the last two
    ≤ 0.05 N·m) the model is exactly one-body in q with σ = K(φ(t)). With
    ``reaction_torque`` = 1, an analysis that does not flip the sign finds −K.
    """
    stiffness, static_torque = operating_point_stiffness(p)
    phi = _operating_point(p)
    if p["reaction_torque"] not in (0.0, 1.0):
        raise ValueError("parameter 'reaction_torque' must be 0 or 1")
    trajectory, width = _platform_trajectory(p, rng, phi)

    def operating_angle(t):
        return phi(t, 0)[0]

    return Setup(
        kind="rotational", joint=_platform_joint(p, stiffness, static_torque),
        control=operating_angle, trajectory=trajectory, unrecorded_angle=operating_angle,
        torque_sign=-1.0 if p["reaction_torque"] else 1.0, max_damping=p["damping"],
        max_stiffness=max(p["stiffness_min"], p["stiffness_max"]),
        metadata={"damping_law": "linear",
                  "excitation": f"binary steps ±{_fmt(p['step_amplitude'])} rad, "
                                f"Gaussian-smoothed (sd {_fmt(width)} s), position drive",
                  "stiffness_law": "s = s0(phi) + K(phi)*(y - phi), phi = operating point",
                  "operating_point": "phi(t) = c - h*cos(2*pi*t/T)",
                  "angle_recorded": "perturbation y - phi only",
                  "torque_recorded": "reaction (-tau)" if p["reaction_torque"]
                                     else "applied (tau)"})


_ANKLE = {"fs": 1000.0, "duration": 60.0, "torque_noise": 0.05, "encoder_counts": 0.0}

#: (name, kind, description, defaults, build)
DEVICES = [
    ("ankle-coupled", "rotational",
     "ankle seen through a compliant coupling (device angle, sensor torque), resonance 35 Hz",
     {**_ANKLE, "limb_inertia": 0.01, "limb_damping": 1.0, "device_inertia": 0.005,
      "stiffness": 60.0, "stiffness_variation": 0.0, "variation_period": 20.0,
      "rest_angle": 0.0, "coupling_frequency": 35.0, "coupling_damping": 0.3,
      "perturbation_amplitude": 0.03, "hold_min": 0.2, "hold_max": 0.3, "cutoff": 15.0},
     build_ankle_coupled),
    ("ankle-platform", "rotational",
     "ankle on a platform, ±0.06 rad binary steps about an operating point moving "
     "-0.4..0.2 rad (not recorded), K 15 -> 85 N·m/rad",
     {**_ANKLE, "inertia": 0.015, "damping": 1.0, "stiffness_min": 15.0,
      "stiffness_max": 85.0, "stiffness_curvature": 3.0, "operating_angle_min": -0.4,
      "operating_angle_max": 0.2, "operating_period": 40.0, "rest_angle": 0.0,
      "step_amplitude": 0.06, "hold_min": 0.05, "hold_max": 0.2, "cutoff": 15.0,
      "reaction_torque": 0.0},
     build_ankle_platform),
]
