"""A gated stretch reflex with second-order activation on a position-controlled joint.

    python -m benchmarks.generators.gated_reflex OUTDIR [--seeds 3] [--gains 2,4,6,8,10] [--duration 60]

Written from the published design of Guarín & Kearney (Frontiers 2020), independent of
limbstiff's simulator and equations (numpy + scipy only; this is the generator
``benchmarks/reflex_study.py`` has always used, moved here unchanged).

Equations (θ in rad, torque in N·m applied TO the joint, positive towards +θ):

* One-DOF joint, K = 30 N·m/rad, B = 0.8 N·m·s/rad, I = 0.012 kg·m² (constant: the true
  stiffness is K at every sample).
* The angle is prescribed (position-controlled actuator): levels u_j = ±0.03 rad, an independent
  random sign every 200 ms (a PRBS on a 200 ms clock), through a continuous 4th-order Butterworth
  low-pass at 30 Hz (unit DC gain), state x' = A x + b u. The state is propagated exactly
  (matrix exponential; u constant between switches), and θ = c·x, θ̇ = c·A·x, θ̈ = c·A²·x are exact
  (c·b = c·A·b = 0 for a filter of relative degree 4), on a 10 kHz grid.
* Gated reflex torque: drive v(t) = s·G·d·max(d·θ̇(t − δ) − v_th, 0), δ = 40 ms, v_th = 0.5 rad/s
  (nothing below the threshold; above it, the excess stretch velocity); G the gain (N·m·s/rad),
  s = +1 ("resisting": the reflex opposes the stretch, the actuator pushes harder) or −1 (the
  "published" sign); d = ±1 the direction of motion that stretches the muscle. Activation:
  r = H(p) v with H(p) = ω² / (p² + 2ζωp + ω²), ω = 15.6 rad/s, ζ = 0.62 (unit DC gain),
  discretised with a first-order hold at 10 kHz (``scipy.signal.cont2discrete(..., "foh")``).
* Measured torque τ = I·θ̈ + B·θ̇ + K·θ + r + e, e white Gaussian at 15 dB SNR
  (sd = RMS(I·θ̈ + B·θ̇ + K·θ + r) / 10^(15/20)); measured angle quantised by an encoder of
  2^16 counts per revolution (9.6e-5 rad); both picked at 1 kHz from the 10 kHz grid.

One ``rng`` state gives the same perturbation and the same standard-normal noise draws at every
gain and sign (common random numbers): the levels are drawn first, then the noise.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import linalg, signal

from ._common import GeneratedTrial, write_all

K_TRUE, B_TRUE, I_TRUE = 30.0, 0.8, 0.012        # N·m/rad, N·m·s/rad, kg·m²
AMPLITUDE, SWITCH_S, CORNER_HZ, ORDER = 0.03, 0.2, 30.0, 4
DELAY_S, THRESHOLD, OMEGA, ZETA = 0.040, 0.5, 15.6, 0.62
SNR_DB, COUNTS_PER_REV = 15.0, 2 ** 16
FS, FINE = 1000.0, 10                 # sampling rate, Hz; fine steps per sample (10 kHz)
SIGNS = {"resisting": +1, "published": -1}
GAINS = (2.0, 4.0, 6.0, 8.0, 10.0)


def butterworth_state_space() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous Butterworth low-pass of the perturbation as (A, b, c), unit DC gain.

    Returns
    -------
    a : ndarray, shape (4, 4), 1/s
    b : ndarray, shape (4,)
    c : ndarray, shape (4,)
        θ = c·x for the state x' = A x + b u (u in rad).
    """
    z, p, k = signal.butter(ORDER, 2 * np.pi * CORNER_HZ, analog=True, output="zpk")
    a, b, c, _ = signal.zpk2ss(z, p, k)
    return a, b[:, 0], c[0]


def prbs_levels(rng: np.random.Generator, duration: float, amplitude: float = AMPLITUDE) -> np.ndarray:
    """The commanded levels: ``amplitude · (±1)``, one independent random sign per 200 ms slot.

    Parameters
    ----------
    rng : numpy.random.Generator
    duration : float, s
        Covered by ``ceil(duration / 0.2)`` slots.
    amplitude : float, rad

    Returns
    -------
    ndarray, shape (n_slots,), rad
    """
    slots = int(np.ceil(duration / SWITCH_S))
    return amplitude * rng.choice([-1.0, 1.0], size=slots)


def prescribed_motion(levels: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact angle, velocity and acceleration of the filtered step sequence on a fine grid.

    Parameters
    ----------
    levels : ndarray, shape (n_slots,), rad
        Level held during each switching interval.
    dt : float, s
        Fine step; ``SWITCH_S / dt`` must be an integer.

    Returns
    -------
    theta, velocity, acceleration : ndarray, shape (n_slots · SWITCH_S / dt,)
        rad, rad/s, rad/s², at t = 0, dt, 2·dt… (state at rest at the first level for t ≤ 0).
    """
    a, b, c = butterworth_state_space()
    per = int(round(SWITCH_S / dt))
    step = linalg.expm(a * dt)
    powers = np.empty((per, len(b), len(b)))
    powers[0] = np.eye(len(b))
    for j in range(1, per):
        powers[j] = step @ powers[j - 1]
    unit = -np.linalg.solve(a, b)             # steady state per unit input
    x = unit * levels[0]
    states = np.empty((len(levels), per, len(b)))
    for k, u in enumerate(levels):
        states[k] = unit * u + powers @ (x - unit * u)
        x = unit * u + step @ (states[k, -1] - unit * u)
    states = states.reshape(-1, len(b))
    return states @ c, states @ (c @ a), states @ (c @ a @ a)


def reflex_torque(velocity: np.ndarray, dt: float, gain: float, sign: int, direction: int = 1, *,
                  delay_s: float = DELAY_S, threshold: float = THRESHOLD, omega: float = OMEGA,
                  zeta: float = ZETA) -> np.ndarray:
    """Reflex torque the actuator meets: delayed, gated velocity through the activation.

    ``r = H(p)[s·G·d·max(d·θ̇(t − delay) − threshold, 0)]``, ``H = ω²/(p² + 2ζωp + ω²)``
    discretised with a first-order hold at ``dt``.

    Parameters
    ----------
    velocity : ndarray, rad/s
        Joint velocity on the fine grid (at rest before the first sample).
    dt : float, s
        Fine step.
    gain : float, N·m·s/rad
    sign : {+1, −1}
        +1 resists the stretch, −1 the published sign.
    direction : {+1, −1}
        Direction of motion that stretches the muscle.
    delay_s : float, s
        Rounded to a whole number of fine steps.
    threshold : float, rad/s
    omega : float, rad/s
    zeta : float

    Returns
    -------
    ndarray, N·m
        Exactly zero before the sample ``delay`` after the first sample whose stretch velocity
        ``d·θ̇`` exceeds the threshold, nonzero at that sample (the first-order hold passes the
        drive through at once).
    """
    lag = int(round(delay_s / dt))
    delayed = np.concatenate([np.zeros(lag), velocity[:len(velocity) - lag]])
    drive = sign * direction * gain * np.maximum(direction * delayed - threshold, 0.0)
    num, den, _ = signal.cont2discrete(([omega ** 2], [1.0, 2 * zeta * omega, omega ** 2]), dt, method="foh")
    return signal.lfilter(np.ravel(num), den, drive)


def generate(gain: float, sign: int, rng: np.random.Generator, duration: float = 60.0,
             direction: int = 1, *, noise: bool = True) -> dict:
    """One trial of the design: exact kinematics, torques and the measured channels at 1 kHz.

    Parameters
    ----------
    gain : float, N·m·s/rad
        Reflex gain G (0: no reflex).
    sign : {+1, −1}
    rng : numpy.random.Generator
        The levels are drawn first, then ``ceil(duration/0.2)·200`` standard normals (drawn even
        when ``noise`` is False, so the draws do not depend on it).
    duration : float, s
    direction : {+1, −1}
    noise : bool
        False: the torque is the exact I·θ̈ + B·θ̇ + K·θ + r (still quantised angle).

    Returns
    -------
    dict
        ``time`` (s), ``angle`` (quantised, rad), ``torque`` (N·m, with noise), the exact
        ``theta``, ``velocity``, ``acceleration`` and ``reflex`` at the samples, ``noise_sd`` (N·m).
    """
    levels = prbs_levels(rng, duration)
    z = rng.standard_normal(int(round(len(levels) * SWITCH_S * FS)))
    dt = 1.0 / (FS * FINE)
    theta, vel, acc = prescribed_motion(levels, dt)
    reflex = reflex_torque(vel, dt, gain, sign, direction)
    n = int(round(duration * FS))
    pick = np.arange(n) * FINE
    theta, vel, acc, reflex = theta[pick], vel[pick], acc[pick], reflex[pick]
    clean = I_TRUE * acc + B_TRUE * vel + K_TRUE * theta + reflex
    sd = float(np.sqrt(np.mean(clean ** 2)) / 10 ** (SNR_DB / 20)) if noise else 0.0
    q = 2 * np.pi / COUNTS_PER_REV
    return dict(time=np.arange(n) / FS, angle=np.round(theta / q) * q,
                torque=clean + sd * z[:n] if noise else clean,
                theta=theta, velocity=vel, acceleration=acc, reflex=reflex, noise_sd=sd)


def trial(gain: float, sign_name: str, rng: np.random.Generator, *, duration: float = 60.0,
          direction: int = 1, seed_label: str = "", noise: bool = True) -> GeneratedTrial:
    """:func:`generate` as a :class:`GeneratedTrial` whose true stiffness is K = 30 throughout.

    Parameters
    ----------
    gain : float, N·m·s/rad
    sign_name : {"resisting", "published", "none"}
        "none" (gain 0) counts as +1.
    rng : numpy.random.Generator
    duration : float, s
    direction : {+1, −1}
    seed_label : str
        Put in the name and metadata (the caller's seed, for the record).
    noise : bool

    Returns
    -------
    GeneratedTrial
        ``truth`` holds ``theta``, ``velocity``, ``acceleration``, ``reflex``.
    """
    g = generate(gain, SIGNS.get(sign_name, 1), rng, duration, direction, noise=noise)
    params = dict(generator="gated_reflex", K=K_TRUE, B=B_TRUE, I=I_TRUE, amplitude_rad=AMPLITUDE,
                  switch_s=SWITCH_S, corner_hz=CORNER_HZ, order=ORDER, delay_s=DELAY_S,
                  threshold_rad_s=THRESHOLD, omega_rad_s=OMEGA, zeta=ZETA, snr_db=SNR_DB if noise else None,
                  counts_per_rev=COUNTS_PER_REV, fs_hz=FS, gain=gain, sign=sign_name, direction=direction,
                  duration_s=duration, seed=seed_label, noise_sd=g["noise_sd"])
    meta = {"generator": "benchmarks/generators/gated_reflex.py (Guarín & Kearney 2020 design)",
            "reflex_gain": f"{gain:g}", "reflex_sign": sign_name, "direction": str(direction),
            "seed": seed_label}
    name = f"reflex-{sign_name}-G{gain:g}" + (f"-s{seed_label}" if seed_label != "" else "")
    return GeneratedTrial(name=name, time=g["time"], angle=g["angle"], torque=g["torque"],
                          stiffness_true=np.full(len(g["time"]), K_TRUE), metadata=meta,
                          truth={k: g[k] for k in ("theta", "velocity", "acceleration", "reflex")},
                          params=params)


def study_trials(seeds, gains=GAINS, *, duration: float = 60.0, direction: int = 1):
    """The study's trials: gain 0 once, then every gain with both signs, for every seed.

    Each trial's rng is ``numpy.random.default_rng(seed)``, so one seed gives common random
    numbers across gains and signs.

    Yields
    ------
    GeneratedTrial
    """
    for seed in seeds:
        cases = [(0.0, "none")] + [(float(g), s) for g in gains if g for s in SIGNS]
        for gain, sign in cases:
            yield trial(gain, sign, np.random.default_rng(seed), duration=duration, direction=direction,
                        seed_label=str(seed))


def main(argv=None) -> list[Path]:
    """Command line: write the study's trials as CSV files (see the module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m benchmarks.generators.gated_reflex", description=__doc__.split("\n")[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--seeds", type=int, default=3, help="seeds 0 … N−1 (default 3)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--gains", default=",".join(f"{g:g}" for g in GAINS), help="N·m·s/rad, comma-separated")
    ap.add_argument("--duration", type=float, default=60.0, help="s (default 60)")
    ap.add_argument("--direction", type=int, choices=(1, -1), default=1)
    args = ap.parse_args(argv)
    gains = [float(g) for g in args.gains.split(",") if g.strip()]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    paths = write_all(study_trials(seeds, gains, duration=args.duration, direction=args.direction), args.outdir)
    print(f"{len(paths)} trials written to {args.outdir}")
    return paths


if __name__ == "__main__":
    main()
