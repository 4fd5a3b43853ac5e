"""Kalman filter and Rauch–Tung–Striebel smoother for a time-varying stiffness.

State-space model of a recording, one step per (possibly decimated) sample k:

    s[k] = s[k−1] + σ[k−1]·(y[k] − y[k−1]) + g[k]·w_c + w_s    elastic torque: ds = σ·dy
    σ[k] = σ[k−1] + w_σ + w_c                                    stiffness: a random walk
    z[k] = f[k] − m·ÿ[k] − b·ẏ[k] = s[k] + v                     torque left to the elastic element

with w_s ~ N(0, Q_s·Δt), w_σ ~ N(0, Q_σ·Δt), w_c ~ N(0, Q_c·Δt), v ~ N(0, R). The stiffness
walks in two ways. A change w_σ with no torque of its own is a stiffness that depends on the
angle (a nonlinear spring: the torque follows from ds = σ·dy alone). A change w_c of a spring
held at deflection g moves its torque by g·w_c at once (co-contraction, a variable-stiffness
actuator): left out, that torque, in phase with the deflection and so with −ẏ/ω, reads as
damping (on the project's simulated elbows and wrists b came out 4 standard errors low). g is
the angle less its moving average over :data:`DEFLECTION_PERIODS` motion periods
(:func:`deflection`); the slow rest of the deflection is left to w_s. The likelihood sets how
much of the walk is of each kind.

It needs the angle's increments, not its third derivative; the stiffness is observed through
the motion, so its posterior variance grows wherever the joint does not move. The filter's
prediction errors give the exact Gaussian log-likelihood (prediction-error decomposition)
used to fit R, Q_s, Q_σ, Q_c.

The model itself — its steps, passes and likelihoods — is :mod:`limbstiff.statespace`; this
module is the estimator built on it: noise levels by maximum likelihood, the smoothed course
and its responses to m and b, back on the trial's samples. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..statespace.noise import NoiseLevels, fit_levels, noise_bounds
from ..statespace.smoother import at_steps, kalman_loglik, kalman_smoother, to_samples
from ..statespace.linear import course_response
from ..statespace.steps import ModelSteps, model_steps


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
    steps: ModelSteps


def fit_noise_levels(increments: np.ndarray, measured: np.ndarray, *, step: float, deflection: np.ndarray,
                     initial_mean, initial_cov, guess: NoiseLevels, motion_frequency: float,
                     max_evaluations: int = 400, fading: float = 0.0) -> tuple[NoiseLevels, float]:
    """Maximum-likelihood noise levels within :func:`~limbstiff.statespace.noise.noise_bounds`, by
    the one noise fit (:func:`~limbstiff.statespace.noise.fit_levels`) from ``guess``, for the filter
    with the stiffness's fading memory ``fading`` per step (0: none, offline;
    :func:`~limbstiff.statespace.smoother.kalman_loglik`).

    Returns
    -------
    noise : NoiseLevels
    loglik : float
    """
    x0 = guess.logs()
    bounds = noise_bounds(float(np.var(measured)), float(np.sqrt(initial_cov[2])), motion_frequency)

    def loglik(x):
        return kalman_loglik(increments, measured, NoiseLevels(*np.exp(x)), step=step, deflection=deflection,
                             initial_mean=initial_mean, initial_cov=initial_cov, fading=fading)

    best, value = fit_levels(loglik, x0, bounds, max_evaluations)
    return NoiseLevels(*np.exp(best)), value


def data_guess(steps: ModelSteps) -> NoiseLevels:
    """A first guess of the noise levels from the data at ``steps``: the measurement the residual
    of the initial slope's line, the torque walking by as much over the record, the stiffness
    walks by a tenth of the initial slope."""
    y, z, mean0 = steps.angle, steps.measured, steps.initial_mean
    duration = steps.step * len(y)
    resid = float(np.var(z - mean0[1] * (y - y.mean()))) + 1e-300
    walk = (0.1 * abs(mean0[1]) + 1e-12) ** 2
    return NoiseLevels(measurement=resid, torque_walk=resid / duration, stiffness_walk=walk, coupled_walk=walk)


def fit_noise(steps: ModelSteps, *, motion_frequency: float) -> NoiseLevels:
    """Maximum-likelihood noise levels of the model on ``steps`` from :func:`data_guess`
    (:func:`fit_noise_levels`): what :func:`kalman_stiffness` fits, without the smoothing.

    Parameters
    ----------
    steps : ModelSteps
    motion_frequency : float, Hz

    Returns
    -------
    NoiseLevels
    """
    noise, _ = fit_noise_levels(steps.increments, steps.measured, step=steps.step, deflection=steps.deflection,
                                initial_mean=steps.initial_mean, initial_cov=steps.initial_cov,
                                guess=data_guess(steps), motion_frequency=motion_frequency)
    return noise


def kalman_stiffness(angle: np.ndarray, measured: np.ndarray, *, sample_period: float, decimation: int = 1,
                     motion_frequency: float, noise: NoiseLevels | None = None, regressors: tuple = (),
                     scale_from: np.ndarray | None = None,
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
        Typical frequency of the motion (sets the noise bounds and the deflection's average).
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
                     motion_frequency=motion_frequency, scale_from=scale_from)
    idx, z, increments, step, g = st.index, st.measured, st.increments, st.step, st.deflection
    mean0, cov0 = st.initial_mean, st.initial_cov
    if noise is None:
        noise = fit_noise(st, motion_frequency=motion_frequency)
    out = kalman_smoother(increments, z, noise, step=step, deflection=g, initial_mean=mean0, initial_cov=cov0)
    back = to_samples(len(angle), edge, decimation, len(idx))
    responses = np.empty((len(regressors), len(angle)))
    if len(regressors):
        at = course_response(st, np.vstack([np.asarray(reg)[idx] for reg in regressors]), noise)
        for j, row in enumerate(at):
            responses[j] = back(row)
    return KalmanStiffness(stiffness=back(at_steps(out.mean[:, 1])),
                           variance=back(at_steps(np.maximum(out.cov[:, 2], 0.0))),
                           noise=noise, loglik=out.loglik, decimation=decimation, responses=responses, steps=st)
