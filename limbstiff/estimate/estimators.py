"""The three stiffness estimators behind ``--estimator``, on already-differentiated signals.

* ``kalman`` (default): state-space model of :mod:`limbstiff.estimate.kalman` — elastic torque and
  stiffness as states, ds = σ·dy, stiffness a random walk — filtered and RTS-smoothed, noise
  levels by maximum likelihood. No third derivative; gives a posterior variance per sample.
* ``observer-smoothed``: the paper's observer run forwards and backwards in time and fused.
* ``observer``: the paper's update law (7), causal, as in the paper.

Every estimator returns the stiffness, its own variance (noise, lag, lack of motion) and the
observability flag. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..filtered import Filtered
from . import observer
from ..statespace.noise import NoiseLevels
from ..statespace.steps import ModelSteps, kalman_decimation, model_steps
from .kalman import fit_noise, kalman_stiffness


@dataclass(frozen=True)
class EstimatorFit:
    """What an estimator derived from the data besides the stiffness.

    Parameters
    ----------
    noise : NoiseLevels or None
        The Kalman model's noise levels (``kalman``).
    decimation : int or None
        Samples per Kalman step (``kalman``).
    loglik : float or None
        Log-likelihood of the Kalman model at ``noise`` (``kalman``).
    observer_gain : float or None, 1/rad (1/m)
        α (the observers).
    """

    noise: NoiseLevels | None = None
    decimation: int | None = None
    loglik: float | None = None
    observer_gain: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready (``details.estimator`` of ``summary.json``)."""
        if self.noise is not None:
            return {"noise_levels": self.noise.to_dict(), "decimation": self.decimation, "loglik": self.loglik}
        return {"observer_gain": self.observer_gain}


@dataclass(frozen=True)
class Estimate:
    """Output of an estimator.

    Parameters
    ----------
    stiffness : ndarray, shape (n,), N·m/rad (N/m)
    variance : ndarray, shape (n,), (N·m/rad)²
        The estimator's own variance of the stiffness (m and b taken as exact).
    sensitivity : ndarray, shape (2 + k, n), or None
        ∂σ̂/∂m and ∂σ̂/∂b (external variant), then ∂σ̂/∂a for the amplitude a of each effect
        torque given (``extra_regressors``): the estimate is affine in them, so
        σ̂(m', b') = σ̂ + (m' − m)·sensitivity[0] + (b' − b)·sensitivity[1] exactly.
    fit : EstimatorFit
    steps : ModelSteps or None
        The Kalman model's data at its steps (``kalman``), for joint draws of the course.
    """

    stiffness: np.ndarray
    variance: np.ndarray
    sensitivity: np.ndarray | None = None
    fit: EstimatorFit = EstimatorFit()
    steps: ModelSteps | None = None

    def variance_with(self, covariance: np.ndarray | None) -> np.ndarray:
        """Total variance once a covariance (p, p) of (m, b, amplitudes…) is carried through the
        first p rows of the sensitivity."""
        if covariance is None or self.sensitivity is None:
            return self.variance
        c = np.asarray(covariance)
        g = self.sensitivity[:len(c)]
        if len(c) == 2:
            return self.variance + c[0, 0] * g[0] ** 2 + 2 * c[0, 1] * g[0] * g[1] + c[1, 1] * g[1] ** 2
        return self.variance + np.einsum("in,ij,jn->n", g, c, g)


def _measured(filtered: Filtered, inertia: float | None, damping: float | None) -> np.ndarray:
    """What the Kalman model measures: f − m·ÿ − b·ẏ, or the elastic torque (direct variant), N·m (N)."""
    return filtered.elastic_torque(inertia, damping) if inertia is not None else filtered.torque


def kalman_noise(filtered: Filtered, *, inertia: float | None = None, damping: float | None = None) -> NoiseLevels:
    """The noise levels :func:`kalman` fits when given none (maximum likelihood on its model's
    steps, :func:`~limbstiff.estimate.kalman.fit_noise`), without the smoothing."""
    steps = model_steps(filtered.angle, _measured(filtered, inertia, damping), sample_period=filtered.sample_period,
                        decimation=kalman_decimation(filtered.sample_period, filtered.cutoff_hz), edge=filtered.edge,
                        motion_frequency=filtered.motion_hz, scale_from=filtered.torque)
    return fit_noise(steps, motion_frequency=filtered.motion_hz)


def kalman(filtered: Filtered, *, inertia: float | None = None, damping: float | None = None,
           noise: NoiseLevels | None = None, extra_regressors: np.ndarray | None = None) -> Estimate:
    """Kalman/RTS estimate; without ``inertia`` and ``damping`` the direct variant.

    ``extra_regressors`` (k, n): torques per unit amplitude (effects in the model, already taken
    off ``filtered.torque``) whose amplitudes' sensitivities follow m's and b's. Without ``noise``
    the noise levels are fitted (:func:`kalman_noise`).
    """
    external = inertia is not None
    measured = _measured(filtered, inertia, damping)
    regressors = (filtered.acceleration, filtered.velocity) if external else ()
    if external and extra_regressors is not None:
        regressors += tuple(np.atleast_2d(extra_regressors))
    decimation = kalman_decimation(filtered.sample_period, filtered.cutoff_hz)
    fit = kalman_stiffness(filtered.angle, measured, sample_period=filtered.sample_period, decimation=decimation,
                           noise=noise, regressors=regressors, motion_frequency=filtered.motion_hz,
                           scale_from=filtered.torque, edge=filtered.edge)
    return Estimate(fit.stiffness, fit.variance, -fit.responses if external else None,
                    EstimatorFit(noise=fit.noise, decimation=decimation, loglik=fit.loglik), fit.steps)


def _observer_pass(filtered, drive, gain, threshold, discretisation, reverse):
    a, c = observer.recursion_coefficients(filtered.velocity, drive, observer_gain=gain,
                                           sample_period=filtered.sample_period,
                                           discretisation=discretisation, velocity_threshold=threshold)
    # the residual e = r − σ̂·ẏ, seen through the same weights, gives the estimate's spread
    if reverse:
        # Reversed time: odd derivatives change sign, so the velocity becomes −ẏ and the
        # input −(ḟ − m·y⃛ − b·ÿ); the exact step's a and c = (1 − a)·r/ẏ are unchanged.
        est = observer.linear_recursion(a[::-1], c[::-1])[::-1]
    else:
        est = observer.linear_recursion(a, c)
    return est, a


def _spread(a, ratio, est, reverse):
    """Variance of an exponentially weighted mean of the instantaneous ratios r/ẏ."""
    w = 1.0 - a
    dev2 = np.where(w > 0, (ratio - est) ** 2, 0.0)
    num_a, num_c = a * a, w * w * dev2
    if reverse:
        return observer.linear_recursion(num_a[::-1], num_c[::-1])[::-1]
    return observer.linear_recursion(num_a, num_c)


def observers(filtered: Filtered, *, smoothed: bool, gain: float, velocity_threshold: float,
              inertia: float | None = None, damping: float | None = None,
              discretisation: str = "exact") -> Estimate:
    """The paper's observer, causal or forwards–backwards fused.

    The variance is that of the exponentially weighted mean of the instantaneous ratios
    r/ẏ that the exact step computes (weights 1 − a), times the number of samples per
    low-pass correlation length, since neighbouring ratios share their noise.
    """
    v = filtered.velocity
    external = inertia is not None
    drive = (observer.external_drive(filtered.torque_rate, filtered.acceleration, filtered.jerk, inertia=inertia,
                                     damping=damping) if external else filtered.torque_rate)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(np.abs(v) > velocity_threshold, drive / v, 0.0)
    correlated = 1.0 if filtered.cutoff_hz is None else max(1.0, filtered.fs / (2 * filtered.cutoff_hz))
    args = (gain, velocity_threshold, discretisation)
    fwd, a = _observer_pass(filtered, drive, *args, reverse=False)
    var_f = _spread(a, ratio, fwd, reverse=False) * correlated
    # the affine parts (docs/architecture.md, fact 2): the same recursion fed −y⃛ and −ÿ
    sens_f = np.vstack([_observer_pass(filtered, -x, *args, False)[0]
                        for x in (filtered.jerk, filtered.acceleration)]) if external else None
    if not smoothed:
        return Estimate(fwd, var_f, sens_f, EstimatorFit(observer_gain=gain))
    bwd, _ = _observer_pass(filtered, drive, *args, reverse=True)
    var_b = _spread(a, ratio, bwd, reverse=True) * correlated
    # weights: how far the information before (forwards) or after (backwards) each sample has
    # replaced the initial guess, 1 − exp(−α·path), by (8)
    speed = np.where(np.abs(v) > velocity_threshold, np.abs(v), 0.0) * filtered.sample_period
    path = np.cumsum(speed)
    w_f = -np.expm1(-gain * path) + 1e-12
    w_b = -np.expm1(-gain * (path[-1] - path + speed)) + 1e-12
    fused = (w_f * fwd + w_b * bwd) / (w_f + w_b)
    var = (w_f ** 2 * var_f + w_b ** 2 * var_b) / (w_f + w_b) ** 2 + \
        w_f * w_b * (fwd - bwd) ** 2 / (w_f + w_b) ** 2
    sens = None
    if external:
        sens_b = np.vstack([_observer_pass(filtered, -x, *args, True)[0]
                            for x in (filtered.jerk, filtered.acceleration)])
        sens = (w_f * sens_f + w_b * sens_b) / (w_f + w_b)
    return Estimate(fused, var, sens, EstimatorFit(observer_gain=gain))
