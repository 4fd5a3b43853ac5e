"""Kalman filter and Rauch–Tung–Striebel smoother for a time-varying stiffness.

State-space model of a recording, one step per (possibly decimated) sample k:

    s[k] = s[k−1] + σ[k−1]·(y[k] − y[k−1]) + w_s      elastic torque: ds = σ·dy
    σ[k] = σ[k−1] + w_σ                               stiffness: a random walk
    z[k] = f[k] − m·ÿ[k] − b·ẏ[k] = s[k] + v          torque left to the elastic element

with w_s ~ N(0, Q_s·Δt), w_σ ~ N(0, Q_σ·Δt), v ~ N(0, R). It needs the angle's increments,
not its third derivative; the stiffness is observed through the motion, so its posterior
variance grows wherever the joint does not move. The filter's prediction errors give the
exact Gaussian log-likelihood (prediction-error decomposition) used to fit R, Q_s, Q_σ.

Pure numpy; the recursions live in :mod:`limbstiff.estimate.kernels` (compiled when numba is
installed). No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernels


@dataclass(frozen=True)
class NoiseLevels:
    """Variances of the state-space model.

    Parameters
    ----------
    measurement : float, (N·m)²
        R: variance of the torque left to the elastic element, per (decimated) sample.
    torque_walk : float, (N·m)²/s
        Q_s: intensity of elastic-torque changes not explained by σ·dy (s_u·u̇ of the paper).
    stiffness_walk : float, (N·m/rad)²/s
        Q_σ: intensity of the stiffness random walk.
    """

    measurement: float
    torque_walk: float
    stiffness_walk: float

    def to_dict(self) -> dict:
        return {"measurement": self.measurement, "torque_walk": self.torque_walk,
                "stiffness_walk": self.stiffness_walk}

    def logs(self) -> np.ndarray:
        """ln (R, Q_s, Q_σ), shape (3,): the coordinates the noise fits and the sampler work in."""
        return np.log([self.measurement, self.torque_walk, self.stiffness_walk])


def _args(increments, measured, noise, step, initial_mean, initial_cov):
    return (np.ascontiguousarray(increments, dtype=float), np.ascontiguousarray(measured, dtype=float),
            float(noise.measurement), float(noise.torque_walk * step), float(noise.stiffness_walk * step),
            float(initial_mean[0]), float(initial_mean[1]), *map(float, initial_cov))


def kalman_loglik(increments: np.ndarray, measured: np.ndarray, noise: NoiseLevels, *, step: float,
                  initial_mean: tuple[float, float], initial_cov: tuple[float, float, float]) -> float:
    """Exact Gaussian log-likelihood of the measurements (prediction-error decomposition).

    Parameters
    ----------
    increments : ndarray, shape (n,), rad (m)
        y[k] − y[k−1] (the first is ignored).
    measured : ndarray, shape (n,), N·m (N)
        z[k] = f − m·ÿ − b·ẏ.
    noise : NoiseLevels
    step : float, s
        Time between samples Δt.
    initial_mean : (s0, σ0)
    initial_cov : (p11, p12, p22)

    Returns
    -------
    float
    """
    return float(kernels.kalman_loglik(*_args(increments, measured, noise, step, initial_mean, initial_cov)))


@dataclass(frozen=True)
class Smoothed:
    """Smoothed moments of the state [s, σ] at every step.

    Parameters
    ----------
    mean : ndarray, shape (n, 2)
        [s, σ]: elastic torque (N·m) and stiffness (N·m/rad).
    cov : ndarray, shape (n, 3)
        Their covariance [p11, p12, p22].
    loglik : float or None
        Log-likelihood of the measurements (None when not asked for).
    """

    mean: np.ndarray
    cov: np.ndarray
    loglik: float | None


def kalman_smoother(increments: np.ndarray, measured: np.ndarray, noise: NoiseLevels, *, step: float,
                    initial_mean: tuple[float, float], initial_cov: tuple[float, float, float],
                    loglik: bool = True, observed: np.ndarray | None = None) -> Smoothed:
    """Kalman filter then Rauch–Tung–Striebel smoother (arguments as :func:`kalman_loglik`).

    The filter keeps only its filtered moments and the smoother overwrites them with the
    smoothed ones, recomputing the predicted moments on its way back: 5 numbers written per
    step instead of 10, which is most of the pass's cost at these sizes.

    Parameters
    ----------
    loglik : bool
        Also accumulate the log-likelihood (one logarithm per step).
    observed : ndarray of bool, shape (n,), optional
        False where the measurement is to be left out (held-out prediction); default all.

    Returns
    -------
    Smoothed
    """
    args = _args(increments, measured, noise, step, initial_mean, initial_cov)
    observed = np.ones(len(args[1]), dtype=bool) if observed is None else np.ascontiguousarray(observed, dtype=bool)
    mean, cov, value = kernels.kalman_filter(*args[:2], observed, *args[2:], loglik)
    kernels.rts_smoother(args[0], mean, cov, args[3], args[4])
    return Smoothed(mean, cov, float(value) if loglik else None)


@dataclass(frozen=True)
class KalmanStiffness:
    """Smoothed stiffness and what produced it.

    Parameters
    ----------
    stiffness : ndarray, shape (n,), N·m/rad (N/m)
        Posterior mean at every original sample.
    variance : ndarray, shape (n,), (N·m/rad)²
        Posterior variance at every original sample.
    noise : NoiseLevels
        The noise levels used (fitted by maximum likelihood unless given).
    loglik : float
        Log-likelihood of the (decimated) data under ``noise``.
    decimation : int
        Samples of the original rate per filter step.
    responses : ndarray, shape (k, n)
        The smoothed stiffness the same filter gives when fed each extra regressor instead of
        z (zero initial state): since the smoother is linear in z, these are the derivatives
        of the stiffness with respect to the coefficients of those regressors in z.
    steps : ModelSteps
        The data at the filter's steps (for joint draws of the course,
        :mod:`limbstiff.estimate.course_draws`).
    """

    stiffness: np.ndarray
    variance: np.ndarray
    noise: NoiseLevels
    loglik: float
    decimation: int
    responses: np.ndarray
    steps: "ModelSteps"


def initial_slopes(angle: np.ndarray, channels: np.ndarray) -> np.ndarray:
    """The least-squares slope on y of each channel (c, n) over the first tenth (at least 8
    samples): the initial σ of a filter pass over that channel, linear in it. Shape (c,)."""
    n0 = max(8, len(angle) // 10)
    yc = angle[:n0] - angle[:n0].mean()
    yy = float(yc @ yc) or 1.0          # a still start: yc = 0, so every slope is 0
    head = np.atleast_2d(channels)[:, :n0]
    return (head - head.mean(axis=1, keepdims=True)) @ yc / yy


def _initial_mean(angle, measured):
    """[s0, σ0]: the first z and the least-squares slope of z on y over the first tenth.

    Linear in ``measured``, so that the smoother's mean stays linear in z.
    """
    return float(measured[0]), float(initial_slopes(angle, measured)[0])


def initial_cov(angle, scale_from):
    """Diffuse initial covariance from the size of a torque signal (not of z, so that it does
    not change with m and b): var(torque) for s, (sd(torque)/sd(y))² for σ."""
    v = float(np.var(scale_from)) + 1e-300
    return (v, 0.0, v / max(float(np.var(angle)), 1e-300))


def noise_bounds(measured_variance: float, stiffness_scale: float, motion_frequency: float) -> list:
    """Bounds on the logarithms of (R, Q_s, Q_σ) that keep the model observable.

    Upper bounds: by bound (9) of the paper a stiffness that changes faster than the motion
    reveals it cannot be tracked, so within one period of the typical motion the stiffness may
    not walk by more than its own size, nor the non-elastic torque by more than the torque's
    spread: Q_σ ≤ σ²·f_motion, Q_s ≤ var(z)·f_motion, and R ≤ var(z). Without them, data
    sampled finely compared with its residual's correlation time admit a degenerate optimum
    (R → 0, the stiffness jumping to follow every sample). Lower bounds: levels below which a
    term has no visible effect on the estimate — measurement noise of 10⁻⁶·var(z), a
    non-elastic torque walking by 0.1 % of its spread or a stiffness walking by 0.01 % of
    itself per motion period — so that a flat prior on the log scale stays proper and the
    sampler does not wander over decades the data cannot tell apart.
    """
    v = max(measured_variance, 1e-300)
    k2 = max(stiffness_scale ** 2, 1e-300)
    f = motion_frequency
    return [(np.log(1e-6 * v), np.log(v)), (np.log(1e-6 * v * f), np.log(v * f)),
            (np.log(1e-8 * k2 * f), np.log(k2 * f))]


def nelder_mead(loglik, starts, bounds: list, max_evaluations: int = 300):
    """Nelder–Mead over the log noise levels within ``bounds`` from each of ``starts`` (clipped
    to the bounds; initial simplex two log units along each level), the best kept; returns
    (best logs, best value). A non-finite log-likelihood counts as the worst."""
    from scipy.optimize import minimize

    lo, hi = np.array(bounds).T

    def negative(x):
        value = loglik(x)
        return -value if np.isfinite(value) else 1e300

    best = None
    for start in starts:
        x0 = np.clip(np.asarray(start, dtype=float), lo, hi)
        simplex = np.clip(x0 + np.vstack([np.zeros(3), 2.0 * np.eye(3)]), lo, hi)
        res = minimize(negative, x0, method="Nelder-Mead", bounds=bounds,
                       options={"xatol": 0.02, "fatol": 0.01, "maxfev": max_evaluations,
                                "initial_simplex": simplex})
        if best is None or res.fun < best.fun:
            best = res
    return best.x, -float(best.fun)


def maximise(loglik, start: np.ndarray, bounds: list, max_evaluations: int = 300):
    """Nelder–Mead over the log noise levels within ``bounds``; returns (best logs, best value).

    The likelihood can have a second, poorer optimum where the stiffness walks fast and
    explains the torque sample by sample; the search therefore also starts with the
    stiffness walk 10³ times smaller and larger, and keeps the best.
    """
    start = np.asarray(start, dtype=float)
    return nelder_mead(loglik, [start + np.array([0.0, 0.0, shift]) for shift in (0.0, -3 * np.log(10), 3 * np.log(10))],
                       bounds, max_evaluations)


def fit_noise_levels(increments: np.ndarray, measured: np.ndarray, *, step: float, initial_mean,
                     initial_cov, guess: NoiseLevels, motion_frequency: float,
                     max_evaluations: int = 300) -> tuple[NoiseLevels, float]:
    """Maximum-likelihood noise levels within :func:`noise_bounds`.

    Returns
    -------
    noise : NoiseLevels
    loglik : float
    """
    x0 = guess.logs()
    bounds = noise_bounds(float(np.var(measured)), float(np.sqrt(initial_cov[2])), motion_frequency)

    def loglik(x):
        return kalman_loglik(increments, measured, NoiseLevels(*np.exp(x)), step=step,
                             initial_mean=initial_mean, initial_cov=initial_cov)

    best, value = maximise(loglik, x0, bounds, max_evaluations)
    return NoiseLevels(*np.exp(best)), value


@dataclass(frozen=True)
class ModelSteps:
    """The data of the Kalman model at its (decimated) steps.

    Parameters
    ----------
    index : ndarray of int, shape (m,)
        Sample of each step.
    angle, measured, increments : ndarray, shape (m,)
        y (rad), z (N·m) and y[k] − y[k−1] (the first 0) at the steps.
    step : float, s
        Time between steps.
    initial_mean : (float, float)
        [s0, σ0] (:func:`_initial_mean`).
    initial_cov : (float, float, float)
        Diffuse initial covariance (:func:`initial_cov`).
    """

    index: np.ndarray
    angle: np.ndarray
    measured: np.ndarray
    increments: np.ndarray
    step: float
    initial_mean: tuple
    initial_cov: tuple


def model_steps(angle: np.ndarray, measured: np.ndarray, *, sample_period: float, decimation: int, edge: int,
                scale_from: np.ndarray | None = None) -> ModelSteps:
    """Every ``decimation``-th sample between the ``edge`` samples at each end, with the model's
    initial state (arguments as :func:`kalman_stiffness`)."""
    idx = np.arange(edge, len(angle) - edge, decimation)
    y, z = angle[idx], measured[idx]
    return ModelSteps(index=idx, angle=y, measured=z, increments=np.diff(y, prepend=y[0]),
                      step=sample_period * decimation, initial_mean=_initial_mean(y, z),
                      initial_cov=initial_cov(y, z if scale_from is None else np.asarray(scale_from)[idx]))


def kalman_stiffness(angle: np.ndarray, measured: np.ndarray, *, sample_period: float, decimation: int = 1,
                     noise: NoiseLevels | None = None, regressors: tuple = (),
                     motion_frequency: float | None = None, scale_from: np.ndarray | None = None,
                     edge: int = 0) -> KalmanStiffness:
    """Stiffness course by Kalman filtering and RTS smoothing, noise levels from the data.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad (m)
        Angle, low-passed like the torque.
    measured : ndarray, shape (n,), N·m (N)
        z = f − m·ÿ − b·ẏ (external variant) or the elastic torque (direct variant).
    sample_period : float, s
    decimation : int
        Filter on every ``decimation``-th sample (the signals must be low-passed well below
        the decimated Nyquist frequency); results are interpolated back.
    noise : NoiseLevels, optional
        Fixed noise levels; by default fitted by maximum likelihood.
    regressors : tuple of ndarray, shape (n,)
        Signals whose smoothed responses to return (for example ÿ and ẏ: the stiffness
        then changes by −Δm·response₀ − Δb·response₁ when m and b change).
    motion_frequency : float, Hz
        Typical frequency of the motion (needed when ``noise`` is fitted).
    scale_from : ndarray, shape (n,), optional
        Torque whose size sets the diffuse initial covariance (default ``measured``); give the
        recorded torque to keep the estimate exactly affine in m and b.
    edge : int
        Samples at each end left out (unreliable derivatives); the estimate there is the
        nearest one inside, with its variance.

    Returns
    -------
    KalmanStiffness
    """
    st = model_steps(angle, measured, sample_period=sample_period, decimation=decimation, edge=edge,
                     scale_from=scale_from)
    idx, y, z, increments, step = st.index, st.angle, st.measured, st.increments, st.step
    mean0, cov0 = st.initial_mean, st.initial_cov
    if noise is None:
        duration = step * len(y)
        resid = float(np.var(z - mean0[1] * (y - y.mean()))) + 1e-300
        guess = NoiseLevels(measurement=resid, torque_walk=resid / duration,
                            stiffness_walk=(0.1 * abs(mean0[1]) + 1e-12) ** 2)
        noise, _ = fit_noise_levels(increments, z, step=step, initial_mean=mean0, initial_cov=cov0,
                                    guess=guess, motion_frequency=motion_frequency)
    out = kalman_smoother(increments, z, noise, step=step, initial_mean=mean0, initial_cov=cov0)
    back = _regular_grid(len(angle), edge, decimation, len(idx))
    responses = np.empty((len(regressors), len(angle)))
    for j, reg in enumerate(regressors):
        r = np.asarray(reg)[idx]
        resp = kalman_smoother(increments, r, noise, step=step, initial_mean=_initial_mean(y, r), initial_cov=cov0,
                               loglik=False)
        responses[j] = back(at_steps(resp.mean[:, 1]))
    return KalmanStiffness(stiffness=back(at_steps(out.mean[:, 1])),
                           variance=back(at_steps(np.maximum(out.cov[:, 2], 0.0))),
                           noise=noise, loglik=out.loglik, decimation=decimation, responses=responses, steps=st)


def at_steps(values: np.ndarray) -> np.ndarray:
    """The stiffness state at the filter's steps, from its values between them (along the last
    axis of ``values``, shape (..., m)).

    In s[k] = s[k−1] + σ[k−1]·(y[k] − y[k−1]) the state σ[k−1] is the slope over the step from
    k−1 to k: it belongs to the step's middle, half a step before k. The value at step k is
    therefore the mean of σ[k−1] and σ[k] (the first step keeps its own). Placing σ[k] at k
    instead shifts the whole course by half a step, which on a stiffness that follows the
    motion is a bias: on the paper's exponential spring (10 Hz at the end of the sweep) the
    95th-percentile error falls from 1.8 % to 0.3 % with the alignment. Linear, so the
    estimate stays exactly affine in m and b.
    """
    out = np.empty_like(values)
    out[..., 0] = values[..., 0]
    out[..., 1:] = 0.5 * (values[..., :-1] + values[..., 1:])
    return out


def _regular_grid(n: int, start: int, step: int, m: int):
    """Linear interpolation from the samples start, start + step, … (m of them) back to 0…n−1,
    held constant beyond the ends. The grid is regular, so each interval is filled by one
    broadcast (v[j] + (v[j+1] − v[j])·i/step): O(n), no search and no gather."""
    frac = np.arange(step) / step
    last = start + (m - 1) * step

    def back(v):
        out = np.empty(n)
        out[:start] = v[0]
        if m > 1:
            out[start:last] = (v[:-1, None] + np.diff(v)[:, None] * frac).ravel()
        out[last:] = v[-1]
        return out
    return back
