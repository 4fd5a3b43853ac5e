"""Ensembles: small random perturbations on large imposed movement cycles, stiffness by phase.

    python -m benchmarks.generators.ensembles OUTDIR [--seeds 2] [--scenarios smooth,trough,reflex,trough_reflex]

A sibling of ``benchmarks/ensemble_sim.py`` (written apart from limbstiff's method, numpy + scipy
only) that reuses its pieces — the periodic bump, the cosine-series reference, the random binary
sequence, the exact actuator filter, the cycle timing and the delayed rectified reflex — for
the case measured on a real ankle: large imposed cycles (±0.2–0.3 rad, ~1.5 s), a SMALL
perturbation on top (±0.01–0.02 rad), 40–80 cycles, stiffness ~15 → ~120 N·m/rad within the
cycle with, in some trials, a SHARP TROUGH (a dip 50–100 ms wide), stretch reflexes with
25–45 ms delays, and a background torque that varies over the cycle.

Equations (θ in rad, τ in N·m applied TO the joint, positive towards +θ; t in s; 1 kHz):

* Cycles: starts t_k (period P, optionally jittered 5–10 %, ``ensemble_sim._cycle_starts``);
  phase φ = (t − t_k)/(t_{k+1} − t_k) ∈ [0, 1), rate φ̇ = 1/(t_{k+1} − t_k).
* Imposed movement: θ_r(φ) = a0 + Σ_{h=1..3} a_h cos(2πhφ), a = A·(1, −0.3, 0.15)/span scaled so
  that max θ_r − min θ_r = 2A exactly, centred on ``movement_centre``; θ̇_r, θ̈_r analytic
  (``ensemble_sim._ref_eval``).
* Perturbation: command u(t) = a_p·b(t), b = ±1 on a ``clock_ms`` clock, switching with
  probability 1/2 at each tick (``ensemble_sim._binary``); the device follows it through an
  80 Hz lag then a 2nd-order stage (``actuator_hz``, ζ 0.7), unit DC gain, discretised exactly
  with u held over each sample (``ensemble_sim._lowpass2``): x, ẋ, ẍ exact.
* Angle θ = θ_r(φ) + x.
* Intrinsic stiffness: K_0(φ) = k_low + (k_high − k_low)·β(φ; c_k, w_k), with the flat-topped
  periodic bump β(φ; c, w) = exp(−(|((φ − c + ½) mod 1) − ½| / w)^4) (``ensemble_sim._bump``);
  with a trough at φ_t of full width at half depth w_t (phase units, = width_s / P):
  K(φ) = K_0(φ) + (k_min − K_0(φ))·g(φ), g(φ) = cos²(π d / (2 w_t)) for |d| < w_t, else 0,
  d = ((φ − φ_t + ½) mod 1) − ½. So K(φ_t) = k_min exactly, K is halfway between K_0 and k_min
  at d = ±w_t/2, K = K_0 for |d| ≥ w_t; k_min ≤ min K_0 over the trough is required (then k_min
  is K's minimum there).
* Stretch reflex (perturbation-relative, as in ``ensemble_sim``):
  r = LP2[G(φ)·max(ẋ(t − δ) − v_th, 0)], LP2 = 2nd-order low-pass 3.5 Hz, ζ 0.7, unit DC gain,
  input held over each 1 ms sample (``ensemble_sim._reflex_from_velocity``); δ ∈ 25–45 ms
  (rounded to 1 ms), v_th = 0.01 rad/s, G(φ) = G0·(f + (1 − f)·β(φ; c_r, w_r)) N·m·s/rad.
  r is zero up to the sample δ after the first sample whose ẋ exceeds v_th and nonzero from the
  next one (the held input starts there).
* Background torque: τ_bg(φ) = T0 + T1·β(φ; c_b, w_b) + T2·sin(2πφ + ψ).
* Torque: τ = τ_bg(φ) + I·θ̈ + B·θ̇ + K(φ)·x + r + e, with e ~ N(0, (ν·sd(τ − e))²), ν the
  ``noise_frac``; the recorded angle is θ quantised to 2^16 counts per revolution.
  The true stiffness at each sample is K(φ(t)); the true stiffness by phase bin is the mean of
  K over the bin (:func:`benchmarks.generators._common.bin_means`).
"""
from __future__ import annotations

import argparse
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from scipy import optimize

from benchmarks import ensemble_sim as es

from ._common import GeneratedTrial, write_all

FS = es.FS                         # Hz
V_TH = es.V_TH                     # reflex velocity threshold, rad/s
REF_SHAPE = np.array([1.0, -0.3, 0.15])    # cosine-series shape of the imposed movement
TRUTH_POINTS = 4001                # fine phase grid of the true curve
MARKER_S = 0.010                   # marker high at each cycle start, s


@dataclass(frozen=True)
class Trough:
    """A narrow dip of the stiffness.

    Parameters
    ----------
    centre : float
        Phase φ_t of the minimum, in [0, 1).
    width_s : float, s
        Full width at half depth (converted to phase by the nominal period).
    k_min : float, N·m/rad
        K(φ_t).
    """

    centre: float
    width_s: float
    k_min: float


@dataclass(frozen=True)
class Settings:
    """Everything that defines an ensemble except the random perturbation, cycle jitter and noise.

    Units: s, rad, N·m/rad (stiffness), N·m·s/rad (damping, reflex gain), kg·m², N·m (torque),
    phases in [0, 1). See the module docstring for the equations.
    """

    n_cycles: int = 40
    period_s: float = 1.5
    unequal: bool = True
    movement_amp: float = 0.25
    movement_centre: float = 0.0
    perturbation_amp: float = 0.015
    clock_ms: int = 40
    actuator_hz: float = 30.0
    inertia: float = 0.015
    damping: float = 1.0
    k_low: float = 15.0
    k_high: float = 120.0
    k_peak: float = 0.35
    k_width: float = 0.2
    trough: Trough | None = None
    reflex_gain: float = 0.0
    reflex_delay_s: float = 0.035
    reflex_floor: float = 0.25
    reflex_peak: float = 0.35
    reflex_width: float = 0.2
    bg_mean: float = -3.0
    bg_bump: float = -15.0
    bg_peak: float = 0.4
    bg_width: float = 0.2
    bg_wave: float = 2.0
    bg_wave_phase: float = 0.0
    noise_frac: float = 0.01
    quantise: bool = True


def wrapped(phi, centre: float) -> np.ndarray:
    """Signed phase distance ((φ − centre + ½) mod 1) − ½, in [−½, ½)."""
    return (np.asarray(phi, dtype=float) - centre + 0.5) % 1.0 - 0.5


def trough_window(phi, centre: float, width: float) -> np.ndarray:
    """g(φ) = cos²(π d / (2 w)) for |d| < w, else 0 (d = :func:`wrapped`): 1 at the centre,
    ½ at d = ±w/2 (so w is the full width at half depth), 0 from |d| = w on, C¹ throughout."""
    d = wrapped(phi, centre)
    return np.where(np.abs(d) < width, np.cos(np.pi * d / (2 * width)) ** 2, 0.0)


def stiffness(phi, s: Settings) -> np.ndarray:
    """True intrinsic stiffness K(φ), N·m/rad (module docstring).

    Raises
    ------
    ValueError
        A trough whose k_min exceeds K_0 somewhere inside it (then k_min would not be its minimum).
    """
    phi = np.asarray(phi, dtype=float)
    k0 = s.k_low + (s.k_high - s.k_low) * es._bump(phi, s.k_peak, s.k_width)
    if s.trough is None:
        return k0
    width = s.trough.width_s / s.period_s
    g = trough_window(phi, s.trough.centre, width)
    inside = s.trough.centre + np.linspace(-width, width, 201)
    if s.trough.k_min > np.min(s.k_low + (s.k_high - s.k_low) * es._bump(inside, s.k_peak, s.k_width)):
        raise ValueError(f"trough k_min {s.trough.k_min} exceeds the stiffness around it")
    return k0 + (s.trough.k_min - k0) * g


def background_torque(phi, s: Settings) -> np.ndarray:
    """τ_bg(φ) = T0 + T1·β(φ; c_b, w_b) + T2·sin(2πφ + ψ), N·m."""
    phi = np.asarray(phi, dtype=float)
    return (s.bg_mean + s.bg_bump * es._bump(phi, s.bg_peak, s.bg_width)
            + s.bg_wave * np.sin(2 * np.pi * phi + s.bg_wave_phase))


def reflex_gain(phi, s: Settings) -> np.ndarray:
    """G(φ) = G0·(f + (1 − f)·β(φ; c_r, w_r)), N·m·s/rad."""
    return s.reflex_gain * (s.reflex_floor + (1 - s.reflex_floor) * es._bump(phi, s.reflex_peak, s.reflex_width))


def reference_coefficients(amp: float, centre: float) -> tuple[float, np.ndarray]:
    """(a0, a_1..a_3) of θ_r(φ) = a0 + Σ a_h cos(2πhφ) with max − min = 2·amp, centred on ``centre``.

    The extremes are found on a 20001-point phase grid, then refined by a bounded scalar search
    (the span is exact to ~1e-12 rad).
    """
    grid = np.linspace(0.0, 1.0, 20001)

    def shape(p):
        return es._ref_eval(np.atleast_1d(p), 1.0, 0.0, REF_SHAPE)[0]

    values, step = shape(grid), grid[1]

    def extreme(sign):
        k = int(np.argmax(sign * values))
        best = optimize.minimize_scalar(lambda p: -sign * shape(p)[0], bounds=(grid[k] - step, grid[k] + step),
                                        method="bounded", options={"xatol": 1e-12})
        return max(sign * values[k], -best.fun) * sign

    hi, lo = extreme(1.0), extreme(-1.0)
    scale = 2 * amp / (hi - lo)
    return centre - 0.5 * (hi + lo) * scale, REF_SHAPE * scale


def simulate(s: Settings, rng: np.random.Generator, name: str = "ensemble", *, noise: bool = True) -> GeneratedTrial:
    """Simulate one ensemble trial (equations in the module docstring).

    Parameters
    ----------
    s : Settings
    rng : numpy.random.Generator
        Draws, in order: the cycle timing, the perturbation's binary sequence, the torque noise.
    name : str
    noise : bool
        False: no torque noise and no angle quantisation (the exact channels).

    Returns
    -------
    GeneratedTrial
        ``truth``: ``theta``, ``velocity``, ``acceleration``, ``reference``, ``perturbation``
        (x), ``perturbation_velocity``, ``command`` (u), ``reflex`` (r), ``background``
        (τ_bg), ``clean_torque``; ``truth_grid``/``truth_curve`` K(φ) on 4001 phases;
        ``phase`` NaN outside the recorded whole cycles.
    """
    starts, t_end, jitter = es._cycle_starts(s.n_cycles, s.period_s, s.unequal, rng)
    n = int(np.floor(t_end * FS)) + 1
    t = np.arange(n) / FS
    k = np.searchsorted(starts, t, side="right") - 1
    rate = 1.0 / (starts[k + 1] - starts[k])
    phi = (t - starts[k]) * rate
    a0, coef = reference_coefficients(s.movement_amp, s.movement_centre)
    th_r, thv_r, tha_r = es._ref_eval(phi, rate, a0, coef)
    u = s.perturbation_amp * es._binary(n + s.clock_ms, rng, s.clock_ms)[:n]
    x, xv, xa = es._lowpass2(u, s.actuator_hz, 0.7, 1.0 / FS, es.POLE_HZ)
    gain = reflex_gain(phi, s)
    r = es._reflex_from_velocity(xv, gain, s.reflex_delay_s, V_TH, 1.0 / FS) if s.reflex_gain else np.zeros(n)
    kk, bg = stiffness(phi, s), background_torque(phi, s)
    theta, vel, acc = th_r + x, thv_r + xv, tha_r + xa
    clean = bg + s.inertia * acc + s.damping * vel + kk * x + r
    sd = s.noise_frac * float(np.std(clean)) if noise else 0.0
    torque = clean + rng.normal(0.0, sd, n) if noise else clean.copy()
    angle = np.round(theta / es.Q_ANGLE) * es.Q_ANGLE if noise and s.quantise else theta.copy()
    inside = starts[(starts >= 0) & (starts <= t[-1])]
    marker = np.zeros(n)
    for st in inside:
        first = int(np.ceil(st * FS - 1e-9))
        marker[first:first + int(round(MARKER_S * FS))] = 1.0
    phase = np.where((t >= inside[0]) & (t < inside[-1]), phi, np.nan)
    grid = np.linspace(0.0, 1.0, TRUTH_POINTS)
    params = dict(generator="ensembles", settings=asdict(s), reflex_threshold_rad_s=V_TH,
                  reflex_lowpass_hz=3.5, reflex_lowpass_zeta=0.7, actuator_zeta=0.7, actuator_lag_hz=es.POLE_HZ,
                  movement_a0=a0, movement_coef=coef, period_jitter=jitter, cycle_starts_s=inside,
                  noise_sd=sd, counts_per_rev=2 ** 16 if noise and s.quantise else None, fs_hz=FS)
    meta = {"generator": "benchmarks/generators/ensembles.py", "cycles": str(s.n_cycles),
            "period_s": f"{s.period_s:g}", "perturbation_amp_rad": f"{s.perturbation_amp:g}",
            "trough": "none" if s.trough is None else
            f"phase {s.trough.centre:.3f}, {1000 * s.trough.width_s:.0f} ms, {s.trough.k_min:g} N·m/rad",
            "reflex_gain": f"{s.reflex_gain:g}",
            "reflex_delay_ms": f"{1000 * s.reflex_delay_s:g}" if s.reflex_gain else "none"}
    truth = dict(theta=theta, velocity=vel, acceleration=acc, reference=th_r, perturbation=x,
                 perturbation_velocity=xv, command=u, reflex=r, background=bg, clean_torque=clean)
    return GeneratedTrial(name=name, time=t, angle=angle, torque=torque, stiffness_true=kk, metadata=meta,
                          truth=truth, params=params, marker=marker, phase=phase, truth_grid=grid,
                          truth_curve=stiffness(grid, s))


#: Scenarios: which features a trial has; the rest is drawn by :func:`draw_settings`.
SCENARIOS = {
    "smooth": dict(trough=False, reflex=False),
    "trough": dict(trough=True, reflex=False),
    "reflex": dict(trough=False, reflex=True),
    "trough_reflex": dict(trough=True, reflex=True),
}


def draw_settings(scenario: str, rng: np.random.Generator) -> Settings:
    """Random settings of a scenario, in the measured ranges (ankle-like).

    Draws (uniform unless said): cycles 40–80 (integer), period 1.5 s (jittered 5–10 %),
    movement ±0.2–0.3 rad, perturbation ±0.01–0.02 rad on a 40 or 60 ms clock, actuator
    20–40 Hz, I 0.01–0.02 kg·m², B 0.5–1.5 N·m·s/rad, k_low 12–20, k_high 100–130 N·m/rad,
    stiffness peak at phase 0.3–0.45 (width 0.18–0.25); a trough at 0.03–0.10 of a cycle
    from the peak (either side), 50–100 ms wide, k_min 15–40 N·m/rad; a reflex of gain 1–4
    N·m·s/rad, delay 25–45 ms (whole ms), floor 0.2–0.4; background −2…−5 N·m plus a −10…−25 N·m
    bump and a 1–3 N·m first harmonic; noise 0.5–2 % of the torque's sd.

    Parameters
    ----------
    scenario : str
        A key of :data:`SCENARIOS`.
    rng : numpy.random.Generator
    """
    spec = SCENARIOS[scenario]
    u = rng.uniform
    peak = u(0.3, 0.45)
    trough = Trough(centre=(peak + rng.choice([-1, 1]) * u(0.03, 0.10)) % 1.0, width_s=u(0.05, 0.10),
                    k_min=u(15.0, 40.0))
    return Settings(n_cycles=int(rng.integers(40, 81)), period_s=1.5, unequal=True,
                    movement_amp=u(0.2, 0.3), perturbation_amp=u(0.01, 0.02),
                    clock_ms=int(rng.choice([40, 60])), actuator_hz=u(20.0, 40.0),
                    inertia=u(0.01, 0.02), damping=u(0.5, 1.5), k_low=u(12.0, 20.0), k_high=u(100.0, 130.0),
                    k_peak=peak, k_width=u(0.18, 0.25), trough=trough if spec["trough"] else None,
                    reflex_gain=u(1.0, 4.0) if spec["reflex"] else 0.0,
                    reflex_delay_s=int(rng.integers(25, 46)) / 1000.0, reflex_floor=u(0.2, 0.4),
                    reflex_peak=peak + u(-0.05, 0.05), bg_mean=u(-5.0, -2.0), bg_bump=u(-25.0, -10.0),
                    bg_peak=u(0.3, 0.5), bg_wave=u(1.0, 3.0), bg_wave_phase=u(0, 2 * np.pi),
                    noise_frac=u(0.005, 0.02))


def scenario_trial(scenario: str, seed: int, **overrides) -> GeneratedTrial:
    """One trial of a scenario: ``rng = numpy.random.default_rng([seed, index of scenario])``
    draws the settings (:func:`draw_settings`, then ``overrides`` replace fields) and then the
    trial (:func:`simulate`); named ``ens-<scenario>-s<seed>``."""
    rng = np.random.default_rng([seed, list(SCENARIOS).index(scenario)])
    s = replace(draw_settings(scenario, rng), **overrides)
    return simulate(s, rng, name=f"ens-{scenario}-s{seed}")


def main(argv=None) -> list[Path]:
    """Command line: write every scenario for seeds ``first … first + N − 1`` (module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m benchmarks.generators.ensembles", description=__doc__.split("\n")[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--seeds", type=int, default=2, help="number of seeds per scenario (default 2)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma-separated, of: " + ", ".join(SCENARIOS))
    ap.add_argument("--cycles", type=int, default=None, help="override the drawn number of cycles")
    args = ap.parse_args(argv)
    names = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = sorted(set(names) - set(SCENARIOS))
    if unknown:
        ap.error(f"unknown scenario(s) {', '.join(unknown)}")
    extra = {} if args.cycles is None else {"n_cycles": args.cycles}
    trials = (scenario_trial(name, seed, **extra) for seed in range(args.first_seed, args.first_seed + args.seeds)
              for name in names)
    paths = write_all(trials, args.outdir)
    print(f"{len(paths)} trials written to {args.outdir} (read the cycles with a protocol whose "
          f'[cycles] says marker = "marker")')
    return paths


if __name__ == "__main__":
    main()
