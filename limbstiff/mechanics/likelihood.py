"""Inertia and damping under the Kalman model: the marginal likelihood of the noise levels.

z = f − m·ÿ − b·ẏ is linear in (m, b) and the filter's covariance does not depend on the data,
so one filter pass over the channels (f, ÿ, ẏ) gives the likelihood as a quadratic form in
(1, −m, −b); m and b integrate out exactly under a flat prior. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..estimate import kalman as kalman_model
from ..statespace import kernels
from ..statespace.noise import maximise, noise_bounds
from .least_squares import LeastSquaresFit


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
    noise : kalman_model.NoiseLevels
    loglik : float
        Log marginal likelihood of the noise levels (m and b integrated out, flat prior).
    """

    inertia: float
    damping: float
    covariance: np.ndarray
    noise: kalman_model.NoiseLevels
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

    The fields are the model's data at the steps used: the angle's increments and the spring's
    deflection (n,), the channels (f, ÿ, ẏ) (3, n) with their initial slopes on y (3,), the
    diffuse initial covariance, the step (s), the noise levels' bounds (4, 2), where the filter
    restarts (n,) and the sample of each step (``index``, (n,)).
    """

    increments: np.ndarray
    deflection: np.ndarray
    channels: np.ndarray
    slopes: np.ndarray
    initial_cov: tuple
    step: float
    bounds: np.ndarray
    restart: np.ndarray
    index: np.ndarray

    @classmethod
    def build(cls, angle, velocity, acceleration, torque, *, sample_period: float, decimation: int,
              motion_frequency: float, guess: LeastSquaresFit, edge: int = 0) -> "MechanicsProblem":
        idx = np.arange(edge, len(angle) - edge, decimation)
        step = sample_period * decimation
        g = kalman_model.deflection(angle[idx], step=step, motion_frequency=motion_frequency)
        restart = np.zeros(len(idx), dtype=bool)
        if len(idx) > MAX_IDENTIFY_STEPS:
            size = MAX_IDENTIFY_STEPS // IDENTIFY_BLOCKS
            starts = np.linspace(0, len(idx) - size, IDENTIFY_BLOCKS).astype(int)
            kept = np.concatenate([np.arange(s0, s0 + size) for s0 in starts])
            idx, g = idx[kept], np.ascontiguousarray(g[kept])
            restart = np.zeros(len(idx), dtype=bool)
            restart[::size] = True
        y = np.ascontiguousarray(angle[idx], dtype=float)
        chans = np.ascontiguousarray(np.vstack([torque[idx], acceleration[idx], velocity[idx]]), dtype=float)
        slopes = kalman_model.initial_slopes(y, chans)
        cov0 = kalman_model.initial_cov(y, chans[0])
        z = chans[0] - guess.inertia * chans[1] - guess.damping * chans[2]
        bounds = np.array(noise_bounds(float(np.var(z)), float(np.sqrt(cov0[2])), motion_frequency))
        return cls(np.diff(y, prepend=y[0]), g, chans, slopes, cov0, step, bounds, restart, idx)

    def conditional(self, log_noise):
        """Log marginal likelihood of the noise levels, and the Gaussian posterior of (m, b).

        Returns
        -------
        loglik : float
        mean : ndarray, shape (2,)
        cov : ndarray, shape (2, 2)
        """
        noise = kalman_model.NoiseLevels(*np.exp(np.asarray(log_noise, dtype=float)))
        ll, m, b, c11, c12, c22 = kernels.marginal_loglik(self.increments, self.deflection, self.channels, self.slopes,
                                                         *noise.per_step(self.step),
                                                         self.initial_cov[0], self.initial_cov[2], self.restart)
        return float(ll), np.array([m, b]), np.array([[c11, c12], [c12, c22]])


def long_run_covariance(scores: np.ndarray, lags: int) -> np.ndarray:
    """Σ_k g_k·g_kᵀ plus the Bartlett-weighted cross terms of lags 1…``lags`` (Newey & West 1987,
    Econometrica 55:703): the variance of Σ g_k when neighbouring terms are correlated.

    Parameters
    ----------
    scores : ndarray, shape (n, p)
    lags : int

    Returns
    -------
    ndarray, shape (p, p)
    """
    out = scores.T @ scores
    for lag in range(1, min(lags, len(scores) - 1) + 1):
        cross = scores[lag:].T @ scores[:-lag]
        out += (1.0 - lag / (lags + 1.0)) * (cross + cross.T)
    return out


#: Lags of the long-run covariance, in periods of the typical motion. A stiffness prior rougher or
#: smoother than the course leaves residuals correlated at the motion's period, positively at short
#: lags and negatively at half a period, so the window must span whole periods for the lobes to
#: cancel (Newey & West's rule ⌊4·(n/100)^(2/9)⌋, 7 lags here, a third of a period, is made for
#: short-range correlation). Measured on 45 simulated trials of ``benchmarks/identify.py`` with the
#: stiffness-change coupling of the closing note of issue 14: the standardised error of b had sd
#: 0.45 (elbows) without lags, 0.68 at one period, 0.79 at three; ankles 0.9–1.0 throughout.
LONG_RUN_PERIODS = 3.0


@dataclass(frozen=True)
class RobustCovariance:
    """The covariance of (m, b) the model gives and the sandwich one.

    Parameters
    ----------
    model : ndarray, shape (2, 2)
        H⁻¹, H = Σ x·xᵀ over the standardised innovations x of ÿ and ẏ.
    sandwich : ndarray, shape (2, 2)
        H⁻¹·M·H⁻¹, M the long-run covariance of the scores x·ε (:func:`long_run_covariance`).
    lag_share : float
        Lags of M ÷ innovations: the b of its fixed-b limit (:mod:`limbstiff.mechanics.fixed_b`).
    """

    model: np.ndarray
    sandwich: np.ndarray
    lag_share: float


def _innovations(problem: "MechanicsProblem", log_noise, channels: np.ndarray, slopes: np.ndarray) -> np.ndarray:
    """Standardised innovations (c, n) of ``channels`` (c, n) at the problem's steps."""
    noise = kalman_model.NoiseLevels(*np.exp(np.asarray(log_noise, dtype=float)))
    e, var = kernels.kalman_channel_innovations(problem.increments, problem.deflection,
                                                np.ascontiguousarray(channels, dtype=float), slopes,
                                                *noise.per_step(problem.step), problem.initial_cov[0],
                                                problem.initial_cov[2], problem.restart)
    return e / np.sqrt(var)


def long_run_lags(motion_frequency: float, step: float) -> int:
    """Lags of the long-run covariance: :data:`LONG_RUN_PERIODS` motion periods of steps."""
    return int(np.ceil(LONG_RUN_PERIODS / (motion_frequency * step)))


def robust_covariance(problem: "MechanicsProblem", log_noise, mean: np.ndarray, *,
                      motion_frequency: float) -> RobustCovariance:
    """The model's covariance of (m, b) at ``log_noise`` and the sandwich one.

    The model's covariance H⁻¹ (H = Σ x·xᵀ over the standardised innovations x of ÿ and ẏ) holds
    when the standardised innovations ε of z are white with unit variance. The sandwich
    H⁻¹·M·H⁻¹, with M the long-run covariance of the scores x·ε (:func:`long_run_covariance`),
    holds without either: a stiffness prior rougher than the course (innovation variances too
    large) or correlated residuals (a reflex, filtered noise) change M, not the estimate.

    Parameters
    ----------
    problem : MechanicsProblem
    log_noise : array, shape (4,)
    mean : ndarray, shape (2,)
        (m, b) at which the residuals are taken.
    motion_frequency : float, Hz
        Sets the lags (:data:`LONG_RUN_PERIODS`).

    Returns
    -------
    RobustCovariance
    """
    e = _innovations(problem, log_noise, problem.channels, problem.slopes)
    x, residual = e[1:].T, e[0] - mean[0] * e[1] - mean[1] * e[2]
    model, sandwich = sandwich_covariance(x, residual, motion_frequency=motion_frequency, step=problem.step)
    return RobustCovariance(model, sandwich, long_run_lags(motion_frequency, problem.step) / len(residual))


def sandwich_covariance(x: np.ndarray, residual: np.ndarray, *, motion_frequency: float,
                        step: float) -> tuple[np.ndarray, np.ndarray]:
    """The model's and the sandwich covariance of a least-squares fit on standardised innovations.

    Parameters
    ----------
    x : ndarray, shape (n, p)
        The regressors' standardised innovations.
    residual : ndarray, shape (n,)
        The standardised innovations of the fitted quantity less ``x`` times the estimate.
    motion_frequency : float, Hz
    step : float, s
        Together set the lags (:data:`LONG_RUN_PERIODS` motion periods).

    Returns
    -------
    model, sandwich : ndarray, shape (p, p)
        H⁻¹ (H = xᵀ·x) and H⁻¹·M·H⁻¹, M the long-run covariance of the scores x·residual.
    """
    h_inv = np.linalg.inv(x.T @ x)
    return h_inv, h_inv @ long_run_covariance(x * residual[:, None], long_run_lags(motion_frequency, step)) @ h_inv


def kalman_mechanics(problem: MechanicsProblem, *, guess: LeastSquaresFit,
                     max_evaluations: int = 400) -> MechanicsFit:
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
    resid_var = max(guess.residual_sd ** 2, 1e-300)
    duration = problem.step * len(problem.increments)
    walk = (0.1 * abs(problem.slopes[0]) + 1e-12) ** 2
    start = np.log([resid_var, resid_var / duration, walk, walk])
    best, _ = maximise(lambda logs: problem.conditional(logs)[0], start, list(problem.bounds),
                                 max_evaluations)
    loglik, mean, cov = problem.conditional(best)
    return MechanicsFit(inertia=float(mean[0]), damping=float(mean[1]), covariance=cov,
                        noise=kalman_model.NoiseLevels(*np.exp(best)), loglik=loglik)
