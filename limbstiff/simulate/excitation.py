"""Excitation and schedule signals: chirp, multisine, sinusoid, random and binary steps, ramps,
gates.

Every signal is a pure function of a time array. Signals that a position drive imposes
return their analytic time derivatives too, as an array of shape ``(derivatives + 1, n)``
(value, first, second and third derivative), so that velocity, acceleration and jerk of a
prescribed motion are exact. Random choices (multisine phases, step times and levels) are
drawn beforehand from an explicit :class:`numpy.random.Generator`.
"""

from __future__ import annotations

import math

import numpy as np

_MAX_DERIVATIVES = 3


def _time_and_order(t: np.ndarray, derivatives: int) -> tuple[np.ndarray, int]:
    """The time array as floats (s) and the number of derivatives asked for, checked (0–3)."""
    if not 0 <= int(derivatives) <= _MAX_DERIVATIVES:
        raise ValueError(f"derivatives must be 0..{_MAX_DERIVATIVES}, got {derivatives}")
    return np.asarray(t, dtype=float), int(derivatives)


def _sin_of_phase(phase: np.ndarray, d1: np.ndarray, d2, d3, derivatives: int) -> np.ndarray:
    """Derivatives of sin(phi(t)) from the derivatives d1, d2, d3 of phi."""
    s, c = np.sin(phase), np.cos(phase)
    out = [s]
    if derivatives >= 1:
        out.append(c * d1)
    if derivatives >= 2:
        out.append(-s * d1**2 + c * d2)
    if derivatives >= 3:
        out.append(-c * d1**3 - 3.0 * s * d1 * d2 + c * d3)
    return np.array(out)


def sinusoid(t: np.ndarray, amplitude: float, omega: float, phase: float = 0.0,
             derivatives: int = 0) -> np.ndarray:
    """A sin(ωt + φ) and its time derivatives.

    Parameters
    ----------
    t : ndarray, shape (n,), s
    amplitude : float
        A, in the unit of the signal.
    omega : float
        Angular frequency ω, rad/s.
    phase : float
        φ, rad.
    derivatives : int
        How many time derivatives to return (0–3).

    Returns
    -------
    ndarray, shape (derivatives + 1, n)
        Row k: the k-th time derivative of A sin(ωt + φ), in the unit of A per s^k.
    """
    t, derivatives = _time_and_order(t, derivatives)
    phi = omega * t + phase
    zero = np.zeros_like(t)
    return amplitude * _sin_of_phase(phi, np.full_like(t, omega), zero, zero, derivatives)


def chirp(t: np.ndarray, f_start: float, f_end: float, sweep_time: float, *,
          method: str = "logarithmic", phase: float = 0.0, derivatives: int = 0) -> np.ndarray:
    """Unit swept sine sin(φ(t) + phase) and its time derivatives.

    The instantaneous frequency goes from ``f_start`` at t = 0 to ``f_end`` at
    t = ``sweep_time``: exponentially (``"logarithmic"``, f(t) = f0·(f1/f0)^(t/T), equal time
    per octave) or linearly (``"linear"``).

    Parameters
    ----------
    t : ndarray, shape (n,), s
    f_start, f_end : float
        Start and end frequency, Hz (> 0).
    sweep_time : float
        T, s.
    method : {"logarithmic", "linear"}
    phase : float
        Added phase, rad.
    derivatives : int
        How many time derivatives to return (0–3).

    Returns
    -------
    ndarray, shape (derivatives + 1, n)
        Row k: the k-th time derivative of the unit chirp, 1/s^k.
    """
    t, derivatives = _time_and_order(t, derivatives)
    if f_start <= 0 or f_end <= 0 or sweep_time <= 0:
        raise ValueError("chirp needs positive frequencies and sweep time")
    if method == "logarithmic" and not math.isclose(f_start, f_end):
        rate = math.log(f_end / f_start) / sweep_time          # 1/s
        growth = np.exp(rate * t)
        phi = 2.0 * math.pi * f_start * (growth - 1.0) / rate
        d1 = 2.0 * math.pi * f_start * growth
        d2, d3 = d1 * rate, d1 * rate**2
    elif method in ("linear", "logarithmic"):
        slope = (f_end - f_start) / sweep_time                  # Hz/s
        phi = 2.0 * math.pi * (f_start * t + 0.5 * slope * t**2)
        d1 = 2.0 * math.pi * (f_start + slope * t)
        d2 = np.full_like(t, 2.0 * math.pi * slope)
        d3 = np.zeros_like(t)
    else:
        raise ValueError(f"unknown chirp method {method!r} (logarithmic or linear)")
    return _sin_of_phase(phi + phase, d1, d2, d3, derivatives)


def random_phases(rng: np.random.Generator, n: int) -> np.ndarray:
    """n phases uniform on [0, 2π), rad, drawn from ``rng``."""
    return rng.uniform(0.0, 2.0 * math.pi, size=int(n))


def multisine(t: np.ndarray, frequencies: np.ndarray, amplitudes: np.ndarray, *,
              phases: np.ndarray | None = None, rng: np.random.Generator | None = None,
              derivatives: int = 0) -> np.ndarray:
    """Sum of sines Σ A_k sin(2π f_k t + φ_k) and its time derivatives.

    Parameters
    ----------
    t : ndarray, shape (n,), s
    frequencies : ndarray, shape (k,), Hz
    amplitudes : ndarray, shape (k,) or scalar
    phases : ndarray, shape (k,), rad, optional
        Phases φ_k; when omitted they are drawn uniformly from ``rng``.
    rng : numpy.random.Generator, optional
        Source of the random phases (required when ``phases`` is None).
    derivatives : int
        How many time derivatives to return (0–3).

    Returns
    -------
    ndarray, shape (derivatives + 1, n)
        Row k: the k-th time derivative of the sum, in the unit of the amplitudes per s^k.
    """
    t, derivatives = _time_and_order(t, derivatives)
    frequencies = np.atleast_1d(np.asarray(frequencies, dtype=float))
    amplitudes = np.broadcast_to(np.asarray(amplitudes, dtype=float), frequencies.shape)
    if phases is None:
        if rng is None:
            raise ValueError("multisine needs phases or an rng to draw them from")
        phases = random_phases(rng, frequencies.size)
    period = _samples_per_period(t, frequencies)
    if period:
        # Periodic on this uniform grid: compute one period and repeat it.
        one = multisine(t[:period], frequencies, amplitudes, phases=phases,
                        derivatives=derivatives)
        return np.tile(one, (1, -(-t.size // period)))[:, :t.size]
    out = np.zeros((derivatives + 1, t.size))
    for f, a, p in zip(frequencies, amplitudes, phases):
        w = 2.0 * math.pi * f
        arg = w * t + p
        s = np.sin(arg)
        out[0] += a * s
        if derivatives:
            c = np.cos(arg)
            signs = (c, -s, -c)
            for d in range(1, derivatives + 1):
                out[d] += a * w**d * signs[d - 1]
    return out


def _samples_per_period(t: np.ndarray, frequencies: np.ndarray) -> int:
    """Samples in one period of a multisine on the uniform grid t, or 0 if it does not repeat
    on that grid within t (frequencies not on a common grid, or the period not a whole
    number of samples)."""
    if t.size < 4 or frequencies.size == 0:
        return 0
    dt = (t[-1] - t[0]) / (t.size - 1)
    if dt <= 0 or np.ptp(np.diff(t)) > 1e-6 * dt:
        return 0
    f = np.unique(np.abs(frequencies))
    base = float(np.min(np.diff(f))) if f.size > 1 else float(f[0])
    if base <= 0 or np.max(np.abs(f / base - np.round(f / base))) > 1e-6:
        return 0
    samples = 1.0 / (base * dt)
    n = int(round(samples))
    if abs(samples - n) > 1e-6 * samples or n >= t.size:
        return 0
    return n


def draw_random_steps(rng: np.random.Generator, duration: float, amplitude: float,
                      hold_min: float, hold_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Draw a random-level step sequence (pseudo-random position perturbation).

    The level is held for a time uniform on [hold_min, hold_max], then jumps to a new level
    uniform on [−amplitude, amplitude], like the perturbations of a position-controlled
    ankle platform.

    Returns
    -------
    switch_times : ndarray, shape (k,), s
        Times of the jumps (the first one after ``hold_min``).
    levels : ndarray, shape (k + 1,)
        Level before the first jump, then after each jump.
    """
    times = _switch_times(rng, duration, hold_min, hold_max)
    levels = rng.uniform(-amplitude, amplitude, size=len(times) + 1)
    return np.array(times), levels


def _switch_times(rng: np.random.Generator, duration: float, hold_min: float, hold_max: float) -> list[float]:
    """Times of the jumps, s: each level held for a time uniform on [hold_min, hold_max], until
    past ``duration`` + ``hold_max``."""
    if not 0 < hold_min <= hold_max:
        raise ValueError("random steps need 0 < hold_min <= hold_max")
    times, t = [], 0.0
    while t <= duration + hold_max:
        t += rng.uniform(hold_min, hold_max)
        times.append(t)
    return times


def draw_binary_steps(rng: np.random.Generator, duration: float, amplitude: float,
                      hold_min: float, hold_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Draw a PRBS-like step sequence: the level switches between −amplitude and +amplitude.

    Each level is held for a time uniform on [hold_min, hold_max]; the first level's sign
    is drawn at random. Every jump is 2·amplitude.

    Returns
    -------
    switch_times : ndarray, shape (k,), s
        Times of the jumps (the first one after ``hold_min``).
    levels : ndarray, shape (k + 1,)
        ±amplitude, alternating.
    """
    times = _switch_times(rng, duration, hold_min, hold_max)
    first = 1.0 if rng.uniform() < 0.5 else -1.0
    signs = first * (-1.0) ** np.arange(len(times) + 1)
    return np.array(times), amplitude * signs


def gaussian_width(cutoff: float) -> float:
    """Standard deviation (s) of the Gaussian smoothing whose −3 dB frequency is ``cutoff`` Hz."""
    return math.sqrt(math.log(2.0)) / (2.0 * math.pi * cutoff)


def smoothed_steps(t: np.ndarray, switch_times: np.ndarray, levels: np.ndarray,
                   width: float, derivatives: int = 0) -> np.ndarray:
    """A step sequence convolved with a Gaussian of sd ``width``, with exact derivatives.

    Each jump becomes Δ·Φ((t − t_j)/w), Φ the normal CDF, so the signal is band-limited
    (−3 dB at ``0.1325 / width`` Hz) and infinitely smooth.

    Parameters
    ----------
    t : ndarray, shape (n,), s (sorted)
    switch_times : ndarray, shape (k,), s
    levels : ndarray, shape (k + 1,)
    width : float
        Gaussian sd w, s.
    derivatives : int
        How many time derivatives to return (0–3).

    Returns
    -------
    ndarray, shape (derivatives + 1, n)
        Row k: the k-th time derivative of the smoothed steps, in the unit of the levels per s^k.
    """
    from scipy.special import ndtr

    t, derivatives = _time_and_order(t, derivatives)
    switch_times = np.asarray(switch_times, dtype=float)
    jumps = np.diff(levels)
    out = np.zeros((derivatives + 1, t.size))
    # Piecewise-constant levels, then a local correction around each jump.
    out[0] = levels[np.searchsorted(switch_times, t, side="right")]
    reach = 8.0 * width
    lo = np.searchsorted(t, switch_times - reach)
    hi = np.searchsorted(t, switch_times + reach)
    norm = 1.0 / math.sqrt(2.0 * math.pi)
    for tj, dj, a, b in zip(switch_times, jumps, lo, hi):
        if a >= b:
            continue
        u = (t[a:b] - tj) / width
        out[0, a:b] += dj * (ndtr(u) - (u >= 0))
        if derivatives:
            pdf = norm * np.exp(-0.5 * u * u) * dj
            out[1, a:b] += pdf / width
            if derivatives >= 2:
                out[2, a:b] -= u * pdf / width**2
            if derivatives >= 3:
                out[3, a:b] += (u * u - 1.0) * pdf / width**3
    return out


def saturated_ramp(t: np.ndarray, start: float, end: float, value_start: float,
                   value_end: float) -> np.ndarray:
    """Linear ramp from ``value_start`` at ``start`` s to ``value_end`` at ``end`` s.

    Held at the end values outside [start, end] (a saturated ramp).
    """
    t = np.asarray(t, dtype=float)
    if end <= start:
        return np.where(t < start, value_start, value_end).astype(float)
    x = np.clip((t - start) / (end - start), 0.0, 1.0)
    return value_start + (value_end - value_start) * x


def smooth_ramp(t: np.ndarray, start: float, end: float, value_start: float,
                value_end: float) -> np.ndarray:
    """Raised-cosine ramp from ``value_start`` at ``start`` s to ``value_end`` at ``end`` s.

    Continuous first derivative (zero at both ends); held outside [start, end].
    """
    t = np.asarray(t, dtype=float)
    if end <= start:
        return np.where(t < start, value_start, value_end).astype(float)
    x = np.clip((t - start) / (end - start), 0.0, 1.0)
    return value_start + (value_end - value_start) * 0.5 * (1.0 - np.cos(math.pi * x))


def gate(t: np.ndarray, start: float, duration: float, taper: float = 0.0) -> np.ndarray:
    """Window that is 1 except during a pause [start, start + duration], where it is 0.

    With ``taper`` > 0 s the window goes down and back up along raised-cosine edges of that
    length inside the pause; with 0 the edges are steps. ``duration`` ≤ 0 means no pause.
    """
    t = np.asarray(t, dtype=float)
    w = np.ones_like(t)
    if duration <= 0:
        return w
    end = start + duration
    taper = min(max(taper, 0.0), 0.5 * duration)
    inside = (t >= start) & (t <= end)
    w[inside] = 0.0
    if taper > 0:
        down = inside & (t < start + taper)
        w[down] = 0.5 * (1.0 + np.cos(math.pi * (t[down] - start) / taper))
        up = inside & (t > end - taper)
        w[up] = 0.5 * (1.0 + np.cos(math.pi * (end - t[up]) / taper))
    return w


def fade_in(t: np.ndarray, duration: float) -> np.ndarray:
    """Raised-cosine fade from 0 at t = 0 to 1 at ``duration`` s (1 afterwards)."""
    return smooth_ramp(t, 0.0, duration, 0.0, 1.0)
