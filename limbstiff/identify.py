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
    (marginal) likelihood.

    Parameters
    ----------
    inertia, damping : float
        Posterior mean of m (kg·m² or kg) and b (N·m·s/rad or N·s/m) at the fitted noise levels.
    covariance : ndarray, shape (2, 2)
        Their posterior covariance (Gaussian and exact for the linear model, given the noise).
    noise : smoothing.NoiseLevels
    loglik : float
        Log marginal likelihood of the noise levels (m and b integrated out, flat prior).
    """

    inertia: float
    damping: float
    covariance: np.ndarray
    noise: "smoothing.NoiseLevels"
    loglik: float


#: Most filter steps used to identify m, b and the noise levels, and in how many blocks.
MAX_IDENTIFY_STEPS, IDENTIFY_BLOCKS = 6000, 6


@dataclass(frozen=True)
class MechanicsProblem:
    """The decimated data of the state-space model with m and b in the measurement.

    z = f − m·ÿ − b·ẏ is linear in (m, b) and the filter's covariance does not depend on the
    data, so one pass over the channels (f, ÿ, ẏ) gives the likelihood as the quadratic form
    −½·wᵀ·A·w in w = (1, −m, −b) (:func:`kernels.kalman_quadratic`). With a flat prior on (m, b)
    they integrate out exactly, leaving the marginal likelihood of the noise levels, and their
    conditional posterior is Gaussian.

    Long trials are identified on at most :data:`MAX_IDENTIFY_STEPS` filter steps, taken as
    :data:`IDENTIFY_BLOCKS` equal blocks spread over the trial (the filter restarts at each):
    m and b are constant, so a few thousand steps pin them down, and the cost of the posterior
    stops growing with the trial's length.
    """

    increments: np.ndarray
    channels: np.ndarray
    slopes: np.ndarray
    initial_cov: tuple
    step: float
    bounds: np.ndarray
    restart: np.ndarray

    @classmethod
    def build(cls, angle, velocity, acceleration, torque, *, sample_period: float, decimation: int,
              motion_frequency: float, guess: LeastSquaresFit, edge: int = 0) -> "MechanicsProblem":
        from . import smoothing
        idx = np.arange(edge, len(angle) - edge, decimation)
        restart = np.zeros(len(idx), dtype=bool)
        if len(idx) > MAX_IDENTIFY_STEPS:
            size = MAX_IDENTIFY_STEPS // IDENTIFY_BLOCKS
            starts = np.linspace(0, len(idx) - size, IDENTIFY_BLOCKS).astype(int)
            idx = np.concatenate([idx[s0:s0 + size] for s0 in starts])
            restart = np.zeros(len(idx), dtype=bool)
            restart[::size] = True
        y = np.ascontiguousarray(angle[idx], dtype=float)
        chans = np.ascontiguousarray(np.vstack([torque[idx], acceleration[idx], velocity[idx]]), dtype=float)
        n0 = max(8, len(y) // 10)
        yc = y[:n0] - y[:n0].mean()
        yy = float(yc @ yc) or 1.0
        slopes = np.array([yc @ (c[:n0] - c[:n0].mean()) / yy for c in chans])
        cov0 = smoothing._initial_cov(y, chans[0])
        z = chans[0] - guess.inertia * chans[1] - guess.damping * chans[2]
        bounds = np.array(smoothing.noise_bounds(float(np.var(z)), float(np.sqrt(cov0[2])), motion_frequency))
        return cls(np.diff(y, prepend=y[0]), chans, slopes, cov0, sample_period * decimation, bounds, restart)

    def conditional(self, log_noise):
        """Log marginal likelihood of the noise levels, and the Gaussian posterior of (m, b).

        Returns
        -------
        loglik : float
        mean : ndarray, shape (2,)
        cov : ndarray, shape (2, 2)
        """
        from . import kernels
        r, qs, qk = np.exp(np.asarray(log_noise, dtype=float))
        ll, m, b, c11, c12, c22 = kernels.marginal_loglik(self.increments, self.channels, self.slopes, r,
                                                         qs * self.step, qk * self.step,
                                                         self.initial_cov[0], self.initial_cov[2], self.restart)
        return float(ll), np.array([m, b]), np.array([[c11, c12], [c12, c22]])


def kalman_mechanics(problem: MechanicsProblem, *, guess: LeastSquaresFit,
                     max_evaluations: int = 300) -> MechanicsFit:
    """Inertia and damping under the Kalman model, noise levels by maximum marginal likelihood.

    Parameters
    ----------
    problem : MechanicsProblem
        The decimated data (:meth:`MechanicsProblem.build`).
    guess : LeastSquaresFit
        Starting point (its residual sets the first guess of the noise levels).
    max_evaluations : int
        Likelihood evaluations allowed per start of the search.

    Returns
    -------
    MechanicsFit
    """
    from . import smoothing

    resid_var = max(guess.residual_sd ** 2, 1e-300)
    duration = problem.step * len(problem.increments)
    start = np.log([resid_var, resid_var / duration, (0.1 * abs(problem.slopes[0]) + 1e-12) ** 2])
    best, _ = smoothing.maximise(lambda logs: problem.conditional(logs)[0], start, list(problem.bounds),
                                 max_evaluations)
    loglik, mean, cov = problem.conditional(best)
    return MechanicsFit(inertia=float(mean[0]), damping=float(mean[1]), covariance=cov,
                        noise=smoothing.NoiseLevels(*np.exp(best)), loglik=loglik)
