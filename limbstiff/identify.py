"""Identification of inertia and damping from the trial itself.

The model of a recording is f = m·ÿ + b·ẏ + s(y, t): m and b constant over the trial, the
elastic torque s free to vary in time with no assumed form. Over a window short enough for s
to be locally linear, s ≈ k_w·y + c_w; with one (k_w, c_w) per window, m and b follow by
linear least squares after projecting the window terms out (Frisch–Waugh–Lovell), so the
cost is one pass over the data whatever the number of windows.

Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LeastSquaresFit:
    """Point estimate of inertia and damping.

    Parameters
    ----------
    inertia : float, kg·m² (kg)
    damping : float, N·m·s/rad (N·s/m)
    inertia_se, damping_se : float
        Standard errors from the residual variance (white-noise assumption: a lower bound).
    window : float, s
        Length of the windows over which the elastic term was taken as linear in y.
    residual_sd : float, N·m (N)
        Standard deviation of the torque residual.
    condition : float
        Condition number of the (scaled) regressors: large means m and b cannot be told apart
        from the elastic term with this motion (for example a single sinusoid).
    """

    inertia: float
    damping: float
    inertia_se: float
    damping_se: float
    window: float
    residual_sd: float
    condition: float


def _project_out_windows(columns: np.ndarray, angle: np.ndarray, length: int) -> np.ndarray:
    """Residuals of each column after regression on [1, y] within consecutive windows."""
    n = angle.size
    n_win = max(1, n // length)
    edges = np.linspace(0, n, n_win + 1).astype(int)
    out = np.empty_like(columns)
    for lo, hi in zip(edges[:-1], edges[1:]):
        y = angle[lo:hi] - angle[lo:hi].mean()
        block = columns[:, lo:hi] - columns[:, lo:hi].mean(axis=1, keepdims=True)
        yy = y @ y
        slope = block @ y / yy if yy > 0 else np.zeros(len(columns))
        out[:, lo:hi] = block - slope[:, None] * y
    return out


def least_squares(torque: np.ndarray, angle: np.ndarray, velocity: np.ndarray,
                  acceleration: np.ndarray, *, sample_period: float, window: float) -> LeastSquaresFit:
    """Least-squares inertia and damping with a windowed local-linear elastic term.

    Parameters
    ----------
    torque : ndarray, shape (n,), N·m (N)
        External torque f (filtered like the angle).
    angle, velocity, acceleration : ndarray, shape (n,), rad, rad/s, rad/s² (m, m/s, m/s²)
    sample_period : float, s
    window : float, s
        Length of the windows with one linear elastic term each.

    Returns
    -------
    LeastSquaresFit
    """
    length = max(8, int(round(window / sample_period)))
    cols = _project_out_windows(np.vstack([torque, acceleration, velocity]), angle, length)
    f, x = cols[0], cols[1:].T
    scale = np.sqrt(np.sum(x * x, axis=0))
    scale[scale == 0] = 1.0
    xs = x / scale
    coef, *_ = np.linalg.lstsq(xs, f, rcond=None)
    resid = f - xs @ coef
    n_win = max(1, angle.size // length)
    dof = max(1, angle.size - 2 - 2 * n_win)
    s2 = float(resid @ resid) / dof
    cov = s2 * np.linalg.pinv(xs.T @ xs)
    coef = coef / scale
    se = np.sqrt(np.diag(cov)) / scale
    return LeastSquaresFit(inertia=float(coef[0]), damping=float(coef[1]), inertia_se=float(se[0]),
                           damping_se=float(se[1]), window=length * sample_period,
                           residual_sd=float(np.sqrt(s2)), condition=float(np.linalg.cond(xs)))


@dataclass(frozen=True)
class MechanicsFit:
    """Inertia and damping identified with the state-space model, noise levels by maximum
    likelihood.

    Parameters
    ----------
    inertia, damping : float
        Posterior mean of m (kg·m² or kg) and b (N·m·s/rad or N·s/m) at the fitted noise levels.
    covariance : ndarray, shape (2, 2)
        Their posterior covariance (Gaussian, exact for the linear model given the noise).
    noise : smoothing.NoiseLevels
    loglik : float
        Log marginal likelihood of the noise levels (m and b integrated out).
    decimation : int
    """

    inertia: float
    damping: float
    covariance: np.ndarray
    noise: "smoothing.NoiseLevels"
    loglik: float
    decimation: int


def state_space_problem(angle: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray,
                        torque: np.ndarray, *, decimation: int, guess: LeastSquaresFit):
    """Decimated arrays and the diffuse prior of the four-state model [s, σ, m, b].

    Returns
    -------
    arrays : tuple (increments, torque, acceleration, velocity), each shape (n_dec,)
    x0 : ndarray, shape (4,)
    p0 : ndarray, shape (4, 4)
    """
    idx = np.arange(0, len(angle), decimation)
    y, f, a, v = angle[idx], torque[idx], acceleration[idx], velocity[idx]
    z = f - guess.inertia * a - guess.damping * v
    n0 = max(8, len(y) // 10)
    yc = y[:n0] - y[:n0].mean()
    slope = float(yc @ (z[:n0] - z[:n0].mean()) / (yc @ yc)) if yc @ yc > 0 else 0.0
    stiff_scale = max(abs(slope), float(np.std(z)) / max(float(np.std(y)), 1e-300))
    # diffuse: ten times the size of each quantity (m and b from least squares)
    m_sd = 10 * max(abs(guess.inertia), float(np.std(f)) / max(float(np.std(a)), 1e-300) * 0.1)
    b_sd = 10 * max(abs(guess.damping), float(np.std(f)) / max(float(np.std(v)), 1e-300) * 0.1)
    x0 = np.array([z[0], slope, guess.inertia, guess.damping])
    p0 = np.diag([float(np.var(z)) + 1e-12, (10 * stiff_scale) ** 2, m_sd ** 2, b_sd ** 2])
    return (np.diff(y, prepend=y[0]), f, a, v), x0, p0


def kalman_mechanics(angle: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, torque: np.ndarray,
                     *, sample_period: float, decimation: int, guess: LeastSquaresFit,
                     motion_frequency: float, max_evaluations: int = 300) -> MechanicsFit:
    """Inertia and damping as constant states of the Kalman model, noise levels by ML.

    The filter's prediction-error decomposition is the exact likelihood of the noise levels
    with m and b integrated out (under a diffuse Gaussian prior centred on the least-squares
    guess); at its maximum the final filtered state holds the posterior of m and b.

    Parameters
    ----------
    angle, velocity, acceleration : ndarray, shape (n,), rad, rad/s, rad/s²
        Low-passed angle and its derivatives.
    torque : ndarray, shape (n,), N·m
        Low-passed external torque.
    sample_period : float, s
    decimation : int
    guess : LeastSquaresFit
    motion_frequency : float, Hz
        Typical motion frequency (sets the bounds of :func:`smoothing.noise_bounds`).
    max_evaluations : int
        Likelihood evaluations allowed for the noise levels.

    Returns
    -------
    MechanicsFit
    """
    from . import kernels, smoothing

    (d, f, a, v), x0, p0 = state_space_problem(angle, velocity, acceleration, torque,
                                               decimation=decimation, guess=guess)
    step = sample_period * decimation

    def run(logs):
        r, qs, qk = np.exp(np.clip(logs, -300, 300))
        return kernels.kalman_mechanics(d, f, a, v, r, qs * step, qk * step, x0, p0)

    resid_var = max(guess.residual_sd ** 2, 1e-300)
    start = np.log([resid_var, resid_var / (step * len(d)), (0.1 * abs(x0[1]) + 1e-12) ** 2])
    z = f - guess.inertia * a - guess.damping * v
    bounds = smoothing.noise_bounds(float(np.var(z)), float(np.sqrt(p0[1, 1])) / 10, motion_frequency)
    best, _ = smoothing.maximise(lambda logs: run(logs)[0], start, bounds, max_evaluations)
    loglik, x, p = run(best)
    return MechanicsFit(inertia=float(x[2]), damping=float(x[3]), covariance=np.array(p[2:, 2:]),
                        noise=smoothing.NoiseLevels(*np.exp(best)), loglik=float(loglik),
                        decimation=decimation)
