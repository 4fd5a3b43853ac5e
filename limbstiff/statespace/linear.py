"""Coefficients that enter the state-space model's measurement linearly.

z = c₀ − Σ_j β_j·c_j over the channels of :class:`~limbstiff.statespace.steps.ModelSteps`
(f, ÿ, ẏ with β = (m, b); an effect's torque with its amplitude; a stiffness basis with its
weights). The filter's covariance does not depend on the data, so one pass over the channels
gives every channel's innovations e_c with one common variance S, the innovations of z are
Σ w_c·e_c with w = (1, −β), and the log-likelihood is the quadratic form
−½·(n·ln 2π + Σ ln S + wᵀ·A·w), A = Σ e·eᵀ/S (:func:`~limbstiff.statespace.kernels.kalman_quadratic`).
Under a flat prior the β integrate out exactly (:func:`marginal`), leaving the marginal
likelihood of the noise levels and the Gaussian posterior of β; their spread when the model's
noise is not white is the sandwich covariance (:func:`sandwich_covariance`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernels
from .noise import NoiseLevels
from .steps import ModelSteps, initial_slopes


#: Above this many channels the quadratic form is taken from the innovations by a matrix product
#: (:func:`marginal`); at or below it, by the kernel's loop (whose results are the ones recorded).
MANY_CHANNELS = 4


def _pass_args(steps: ModelSteps, noise: NoiseLevels, channels=None, slopes=None) -> tuple:
    chans = steps.channels if channels is None else np.ascontiguousarray(channels, dtype=float)
    return (steps.increments, steps.deflection, chans, steps.slopes if slopes is None else slopes,
            *noise.per_step(steps.step), steps.initial_cov[0], steps.initial_cov[2], steps.restart)


def innovations(steps: ModelSteps, noise: NoiseLevels, *, channels: np.ndarray | None = None,
                slopes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each channel's one-step prediction errors and their common variance.

    Parameters
    ----------
    steps : ModelSteps
    noise : NoiseLevels
    channels : ndarray, shape (k, m), optional
        Other channels to filter at the same steps (default the steps' own), with their initial
        slopes ``slopes`` (k,).

    Returns
    -------
    innovations : ndarray, shape (c, m)
    variance : ndarray, shape (m,), (N·m)²
    """
    return kernels.kalman_channel_innovations(*_pass_args(steps, noise, channels, slopes))


@dataclass(frozen=True)
class Marginal:
    """The likelihood with the linear coefficients integrated out, and their posterior.

    Parameters
    ----------
    loglik : float
        Log marginal likelihood of the noise levels (flat prior on the coefficients); −inf when
        the data do not determine them.
    coefficients : ndarray, shape (p,)
        Posterior mean of β (the amounts of channels 1… taken from channel 0).
    covariance : ndarray, shape (p, p)
        Their posterior covariance (Gaussian and exact, given the noise levels).
    """

    loglik: float
    coefficients: np.ndarray
    covariance: np.ndarray


def integrate_out(sum_log_s: float, a: np.ndarray, n: int) -> Marginal:
    """The coefficients of channels 1… integrated out of the quadratic form ``a`` (c, c).

    −½·(n·ln 2π + Σ ln S + q_min) + (p/2)·ln 2π − ½·ln det A_pp, q_min the form's minimum over
    the coefficients, reached at A_pp⁻¹·A_p0. Two coefficients (m and b) are solved in closed
    form (:func:`~limbstiff.statespace.kernels.marginal_two`), as the sampler calls this thousands
    of times; more through a linear solve.
    """
    p = a.shape[0] - 1
    if p == 0:
        return Marginal(float(-0.5 * (n * np.log(2 * np.pi) + sum_log_s + a[0, 0])), np.zeros(0), np.zeros((0, 0)))
    if p == 2:
        loglik, mean, cov = kernels.marginal_two(np.array([sum_log_s]), np.ascontiguousarray(a)[None], n)
        return Marginal(float(loglik[0]), mean[0], cov[0])
    app, ap0 = a[1:, 1:], a[1:, 0]
    sign, logdet = np.linalg.slogdet(app)
    if sign <= 0:
        return Marginal(-np.inf, np.full(p, np.nan), np.full((p, p), np.nan))
    beta = np.linalg.solve(app, ap0)
    q_min = a[0, 0] - ap0 @ beta
    loglik = -0.5 * (n * np.log(2 * np.pi) + sum_log_s + q_min) + 0.5 * p * np.log(2 * np.pi) - 0.5 * logdet
    return Marginal(float(loglik), beta, np.linalg.inv(app))


def marginal(steps: ModelSteps, noise: NoiseLevels) -> Marginal:
    """The likelihood of ``noise`` with the coefficients of channels 1… integrated out (module
    docstring), from one filter pass over the channels."""
    if len(steps.channels) > MANY_CHANNELS:
        # the form from the innovations by one matrix product: the kernel's loop over channel
        # pairs grows as c² per step (a curve's weights make c ~ 20)
        args = _pass_args(steps, noise)
        rows, var = kernels.kalman_channel_innovations(args[0], args[1], np.ascontiguousarray(args[2].T).T, *args[3:])
        e = rows.T
        return integrate_out(float(np.sum(np.log(var))), (e.T / var) @ e, steps.channels.shape[1])
    sum_log_s, a = kernels.kalman_quadratic(*_pass_args(steps, noise))
    return integrate_out(sum_log_s, a, steps.channels.shape[1])


def marginal_many(steps: ModelSteps, log_noise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`marginal` at several noise levels: one compiled call for all of them when the
    channels are few (every row equal to its own :func:`marginal` to the bit).

    Parameters
    ----------
    steps : ModelSteps
    log_noise : ndarray, shape (K, 4)
        ln (R, Q_s, Q_σ, Q_c) per row.

    Returns
    -------
    loglik : ndarray, shape (K,)
    coefficients : ndarray, shape (K, p)
    covariance : ndarray, shape (K, p, p)
    """
    log_noise = np.atleast_2d(np.asarray(log_noise, dtype=float))
    c = len(steps.channels)
    if c > MANY_CHANNELS or c == 1:
        out = [marginal(steps, NoiseLevels.from_logs(row)) for row in log_noise]
        return (np.array([o.loglik for o in out]), np.array([o.coefficients for o in out]).reshape(len(out), c - 1),
                np.array([o.covariance for o in out]).reshape(len(out), c - 1, c - 1))
    per_step = np.exp(log_noise) * np.array([1.0, steps.step, steps.step, steps.step])
    args = _pass_args(steps, NoiseLevels(1.0, 1.0, 1.0, 1.0))
    sums, quad = kernels.kalman_quadratic_many(*args[:4], per_step, *args[8:])
    n = steps.channels.shape[1]
    if c == 3:
        return kernels.marginal_two(sums, quad, n)
    out = [integrate_out(float(s_), a, n) for s_, a in zip(sums, quad)]
    return (np.array([o.loglik for o in out]), np.array([o.coefficients for o in out]),
            np.array([o.covariance for o in out]))


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


def long_run_lags(motion_frequency: float, step: float) -> int:
    """Lags of the long-run covariance: :data:`LONG_RUN_PERIODS` motion periods of steps."""
    return int(np.ceil(LONG_RUN_PERIODS / (motion_frequency * step)))


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


def course_response(steps: ModelSteps, columns: np.ndarray, noise: NoiseLevels) -> np.ndarray:
    """The smoothed stiffness course's response to each torque of ``columns`` (k, m) at the steps
    added to z, aligned as the estimate (:func:`~limbstiff.statespace.smoother.at_steps`): the
    smoother is linear in z, so the course from z − u is the course from z less this. Shape (k, m),
    N·m/rad (N/m) per unit of each column."""
    from .smoother import at_steps, kalman_smoother
    columns = np.atleast_2d(np.asarray(columns, dtype=float))
    slopes = initial_slopes(steps.angle, columns)
    return np.vstack([at_steps(kalman_smoother(steps.increments, u, noise, step=steps.step,
                                               deflection=steps.deflection, initial_mean=(float(u[0]), float(k)),
                                               initial_cov=steps.initial_cov, loglik=False).mean[:, 1])
                      for u, k in zip(columns, slopes)])
