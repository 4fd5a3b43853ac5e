"""Inertia and damping under the Kalman model: the marginal likelihood of the noise levels.

z = f − m·ÿ − b·ẏ is linear in (m, b) and the filter's covariance does not depend on the data,
so one filter pass over the channels (f, ÿ, ẏ) gives the likelihood as a quadratic form in
(1, −m, −b); m and b integrate out exactly under a flat prior
(:func:`limbstiff.statespace.linear.marginal`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..statespace.linear import innovations, long_run_lags, marginal, sandwich_covariance
from ..statespace.noise import NoiseLevels, maximise, noise_bounds
from ..statespace.steps import ModelSteps, mechanics_steps
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
    noise : NoiseLevels
    loglik : float
        Log marginal likelihood of the noise levels (m and b integrated out, flat prior).
    """

    inertia: float
    damping: float
    covariance: np.ndarray
    noise: NoiseLevels
    loglik: float


@dataclass(frozen=True)
class MechanicsProblem:
    """What identifying m and b needs: the model's steps with the channels (f, ÿ, ẏ)
    (:func:`~limbstiff.statespace.steps.mechanics_steps`, at most
    :data:`~limbstiff.statespace.steps.MAX_IDENTIFY_STEPS` of them) and the bounds of the log
    noise levels (4, 2), sized on z at the least-squares guess.
    """

    steps: ModelSteps
    bounds: np.ndarray

    @classmethod
    def build(cls, angle, velocity, acceleration, torque, *, sample_period: float, decimation: int,
              motion_frequency: float, guess: LeastSquaresFit, edge: int = 0) -> "MechanicsProblem":
        steps = mechanics_steps(angle, velocity, acceleration, torque, sample_period=sample_period,
                                decimation=decimation, motion_frequency=motion_frequency, edge=edge)
        chans = steps.channels
        z = chans[0] - guess.inertia * chans[1] - guess.damping * chans[2]
        bounds = np.array(noise_bounds(float(np.var(z)), float(np.sqrt(steps.initial_cov[2])), motion_frequency))
        return cls(steps, bounds)

    def conditional(self, log_noise):
        """Log marginal likelihood of the noise levels, and the Gaussian posterior of (m, b).

        Returns
        -------
        loglik : float
        mean : ndarray, shape (2,)
        cov : ndarray, shape (2, 2)
        """
        out = marginal(self.steps, NoiseLevels.from_logs(log_noise))
        return out.loglik, out.coefficients, out.covariance


@dataclass(frozen=True)
class RobustCovariance:
    """The covariance of (m, b) the model gives and the sandwich one.

    Parameters
    ----------
    model : ndarray, shape (2, 2)
        H⁻¹, H = Σ x·xᵀ over the standardised innovations x of ÿ and ẏ.
    sandwich : ndarray, shape (2, 2)
        H⁻¹·M·H⁻¹, M the long-run covariance of the scores x·ε (:func:`~limbstiff.statespace.linear.long_run_covariance`).
    lag_share : float
        Lags of M ÷ innovations: the b of its fixed-b limit (:mod:`limbstiff.mechanics.fixed_b`).
    """

    model: np.ndarray
    sandwich: np.ndarray
    lag_share: float


def robust_covariance(problem: "MechanicsProblem", log_noise, mean: np.ndarray, *,
                      motion_frequency: float) -> RobustCovariance:
    """The model's covariance of (m, b) at ``log_noise`` and the sandwich one.

    The model's covariance H⁻¹ (H = Σ x·xᵀ over the standardised innovations x of ÿ and ẏ) holds
    when the standardised innovations ε of z are white with unit variance. The sandwich
    H⁻¹·M·H⁻¹, with M the long-run covariance of the scores x·ε (:func:`~limbstiff.statespace.linear.long_run_covariance`),
    holds without either: a stiffness prior rougher than the course (innovation variances too
    large) or correlated residuals (a reflex, filtered noise) change M, not the estimate.

    Parameters
    ----------
    problem : MechanicsProblem
    log_noise : array, shape (4,)
    mean : ndarray, shape (2,)
        (m, b) at which the residuals are taken.
    motion_frequency : float, Hz
        Sets the lags (:data:`~limbstiff.statespace.linear.LONG_RUN_PERIODS`).

    Returns
    -------
    RobustCovariance
    """
    e, var = innovations(problem.steps, NoiseLevels.from_logs(log_noise))
    e = e / np.sqrt(var)
    x, residual = e[1:].T, e[0] - mean[0] * e[1] - mean[1] * e[2]
    model, sandwich = sandwich_covariance(x, residual, motion_frequency=motion_frequency, step=problem.steps.step)
    return RobustCovariance(model, sandwich, long_run_lags(motion_frequency, problem.steps.step) / len(residual))


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
    duration = problem.steps.step * len(problem.steps.increments)
    walk = (0.1 * abs(problem.steps.slopes[0]) + 1e-12) ** 2
    start = np.log([resid_var, resid_var / duration, walk, walk])
    best, _ = maximise(lambda logs: problem.conditional(logs)[0], start, list(problem.bounds),
                                 max_evaluations)
    loglik, mean, cov = problem.conditional(best)
    return MechanicsFit(inertia=float(mean[0]), damping=float(mean[1]), covariance=cov,
                        noise=NoiseLevels(*np.exp(best)), loglik=loglik)
