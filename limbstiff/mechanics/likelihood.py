"""Inertia and damping under the Kalman model: the marginal likelihood of the noise levels.

z = f − m·ÿ − b·ẏ is linear in (m, b) and the filter's covariance does not depend on the data,
so one filter pass over the channels (f, ÿ, ẏ) gives the likelihood as a quadratic form in
(1, −m, −b); m and b integrate out exactly under a flat prior
(:func:`limbstiff.statespace.linear.marginal`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..statespace.linear import innovations, long_run_lags, marginal, marginal_many, sandwich_covariance
from ..statespace.noise import NoiseLevels, fit_levels, noise_bounds
from ..statespace.steps import ModelSteps, mechanics_steps
from .least_squares import LeastSquaresFit


@dataclass(frozen=True)
class MechanicsFit:
    """Inertia and damping identified with the state-space model, noise levels by maximum
    (marginal) likelihood.

    Parameters
    ----------
    inertia, damping : float
        Posterior mean of m (kg·m² or kg) and b (N·m·s/rad or N·s/m) at the fitted noise levels
        (NaN when they are given: :attr:`MechanicsProblem.fits_mechanics` False).
    covariance : ndarray, shape (p, p)
        The posterior covariance of the fitted coefficients (m, b, then the effects' amplitudes;
        the amplitudes only when m and b are given): Gaussian and exact for the linear model,
        given the noise.
    noise : NoiseLevels
    loglik : float
        Log marginal likelihood of the noise levels (the coefficients integrated out, flat prior).
    amplitudes : ndarray, shape (k,)
        Posterior mean of the amplitudes of the effects in the model (none without effects).
    """

    inertia: float
    damping: float
    covariance: np.ndarray
    noise: NoiseLevels
    loglik: float
    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass(frozen=True)
class MechanicsProblem:
    """What identifying m and b needs: the model's steps with the channels (f, ÿ, ẏ)
    (:func:`~limbstiff.statespace.steps.mechanics_steps`, at most
    :data:`~limbstiff.statespace.steps.MAX_IDENTIFY_STEPS` of them) and the bounds of the log
    noise levels (4, 2), sized on z at the least-squares guess.

    With effects in the model their torques per unit amplitude follow as channels, and their
    amplitudes are linear coefficients like m and b; with m and b given (``fits_mechanics``
    False) channel 0 is z and the amplitudes are the only coefficients.
    """

    steps: ModelSteps
    bounds: np.ndarray
    fits_mechanics: bool = True

    @classmethod
    def build(cls, angle, velocity, acceleration, torque, *, sample_period: float, decimation: int,
              motion_frequency: float, guess: LeastSquaresFit, edge: int = 0, extra: np.ndarray | None = None,
              given: tuple[float, float] | None = None) -> "MechanicsProblem":
        """The problem on the trial's filtered signals (n,); ``extra`` (k, n) the effects' torques
        per unit amplitude; ``given`` (m, b) when they are not fitted."""
        torque = np.asarray(torque, dtype=float)
        z_given = None if given is None else torque - given[0] * acceleration - given[1] * velocity
        steps = mechanics_steps(angle, velocity, acceleration, torque if given is None else z_given,
                                sample_period=sample_period, decimation=decimation,
                                motion_frequency=motion_frequency, edge=edge, extra=extra,
                                with_mechanics=given is None, scale_from=torque)
        chans = steps.channels
        z = chans[0] - guess.inertia * chans[1] - guess.damping * chans[2] if given is None else chans[0]
        bounds = np.array(noise_bounds(float(np.var(z)), float(np.sqrt(steps.initial_cov[2])), motion_frequency))
        return cls(steps, bounds, given is None)

    @property
    def n_mechanics(self) -> int:
        """How many of the coefficients are m and b (2, or 0 when they are given)."""
        return 2 if self.fits_mechanics else 0

    def conditional(self, log_noise):
        """Log marginal likelihood of the noise levels, and the Gaussian posterior of the
        coefficients (m, b, then the effects' amplitudes).

        Returns
        -------
        loglik : float
        mean : ndarray, shape (p,)
        cov : ndarray, shape (p, p)
        """
        out = marginal(self.steps, NoiseLevels.from_logs(log_noise))
        return out.loglik, out.coefficients, out.covariance

    def conditionals(self, log_noise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`conditional` at each row of ``log_noise`` (K, 4), in one compiled call where
        the channels are few: log-likelihoods (K,), means (K, p), covariances (K, p, p)."""
        return marginal_many(self.steps, log_noise)


@dataclass(frozen=True)
class RobustCovariance:
    """The covariance of the coefficients (m, b, amplitudes) the model gives and the sandwich one.

    Parameters
    ----------
    model : ndarray, shape (p, p)
        H⁻¹, H = Σ x·xᵀ over the standardised innovations x of ÿ and ẏ (and the effects' torques).
    sandwich : ndarray, shape (p, p)
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
    mean : ndarray, shape (p,)
        The coefficients (m, b, amplitudes) at which the residuals are taken.
    motion_frequency : float, Hz
        Sets the lags (:data:`~limbstiff.statespace.linear.LONG_RUN_PERIODS`).

    Returns
    -------
    RobustCovariance
    """
    e, var = innovations(problem.steps, NoiseLevels.from_logs(log_noise))
    e = e / np.sqrt(var)
    x, residual = e[1:].T, e[0] - np.asarray(mean) @ e[1:]
    model, sandwich = sandwich_covariance(x, residual, motion_frequency=motion_frequency, step=problem.steps.step)
    return RobustCovariance(model, sandwich, long_run_lags(motion_frequency, problem.steps.step) / len(residual))


def kalman_mechanics(problem: MechanicsProblem, *, guess: LeastSquaresFit,
                     max_evaluations: int = 400) -> MechanicsFit:
    """Inertia and damping under the Kalman model, noise levels by maximum marginal likelihood
    (the one noise fit, :func:`~limbstiff.statespace.noise.fit_levels`).

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
    best, _ = fit_levels(lambda logs: problem.conditional(logs)[0], start, list(problem.bounds), max_evaluations)
    loglik, mean, cov = problem.conditional(best)
    k = problem.n_mechanics
    m, b = (float(mean[0]), float(mean[1])) if k else (float("nan"), float("nan"))
    return MechanicsFit(inertia=m, damping=b, covariance=cov, noise=NoiseLevels(*np.exp(best)), loglik=loglik,
                        amplitudes=np.asarray(mean[k:], dtype=float))
