"""Inertia and damping of one trial: given, or identified in three steps behind one call.

:func:`identify_mechanics` runs windowed least squares (the starting point), the maximum of the
Kalman model's marginal likelihood, and the emcee posterior, and returns an
:class:`Identification` that keeps each step's result as a typed object (the report's posterior
page and the model checks compare them). Pure numpy (emcee for the sampling): no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..errors import TrialError
from ..filtered import Filtered
from ..interval import Interval
from ..protocol import Protocol
from ..statespace.noise import NoiseLevels
from ..statespace.steps import kalman_decimation
from .angle_error import NO_EFFECT, AngleErrorEffect, angle_error_effect
from .effect_terms import EffectFit, EffectTerms, effect_fits, joined, without_effects
from .least_squares import LeastSquaresFit, least_squares
from .fixed_b import bartlett_fixed_b
from .likelihood import MechanicsFit, MechanicsProblem, kalman_mechanics, robust_covariance
from .posterior import Posterior, sample

#: A quantisation shift of (m, b) larger than this share is not applied (said in the warnings):
#: the simulation measures a small perturbation (on the benchmark's encoders it was under 1 %).
MAX_ANGLE_ERROR_SHIFT = 0.1
#: Identification windows, in periods of the typical motion frequency.
IDENTIFY_PERIODS = 4.0


@dataclass(frozen=True)
class Identification:
    """How inertia and damping were obtained.

    Parameters
    ----------
    method : {"given", "kalman+emcee"}
    inertia, damping : Interval
        kg·m² (kg) and N·m·s/rad (N·s/m); zero width where given.
    covariance : ndarray, shape (2, 2)
        Covariance of (m, b) over the posterior draws (zero where both are given).
    least_squares : LeastSquaresFit or None
    maximum_likelihood : MechanicsFit or None
    posterior : Posterior or None
        Draws of (m, b, log noise levels) with the MCMC diagnostics.
    noise_levels : NoiseLevels or None
        Posterior median of the Kalman model's noise levels.
    decimation : int or None
        Samples per filter step of the likelihood.
    warnings : tuple of str
    expected_inertia : tuple of float or None
        The range of m the protocol expects for the set-up (kg·m²), when it gives one.
    angle_error : AngleErrorEffect
        What the angle's quantisation or noise does to (m, b): its shift is taken off the
        posterior draws and its spread added to them.
    effects : tuple of EffectFit
        The unmodelled effects put in the model, their amplitudes identified with m and b
        (``limbstiff analyze --effect``); none by default.
    basis : tuple of EffectFit
        The weights of the stiffness's curve over a cycle's phase or a schedule
        (:mod:`limbstiff.scheduled`), identified with m, b and the effects; they follow the
        effects in :attr:`coefficients`. None by default.
    """

    method: str
    inertia: Interval
    damping: Interval
    covariance: np.ndarray
    least_squares: LeastSquaresFit | None = None
    maximum_likelihood: MechanicsFit | None = None
    posterior: Posterior | None = None
    noise_levels: NoiseLevels | None = None
    decimation: int | None = None
    warnings: tuple[str, ...] = field(default=())
    expected_inertia: tuple[float, float] | None = None
    angle_error: AngleErrorEffect = NO_EFFECT
    effects: tuple[EffectFit, ...] = ()
    basis: tuple[EffectFit, ...] = ()

    @property
    def given(self) -> bool:
        return self.method == "given"

    @property
    def inertia_in_expected_range(self) -> bool | None:
        """Whether the median inertia lies in :attr:`expected_inertia` (None without a range)."""
        if self.expected_inertia is None:
            return None
        lo, hi = self.expected_inertia
        return bool(lo <= self.inertia.median <= hi)

    @property
    def coefficients(self) -> np.ndarray:
        """Medians of the model's linear coefficients (m, b, the effects' amplitudes…, the curve's
        weights…), shape (2 + k,)."""
        return np.array([self.inertia.median, self.damping.median] +
                        [e.amplitude.median for e in self.effects + self.basis])

    @property
    def coefficient_draws(self) -> np.ndarray | None:
        """Posterior draws of (m, b, amplitudes…), shape (n_draws, 2 + k), given values held fixed;
        None without a posterior."""
        if self.posterior is None:
            return None
        draws = self.posterior.coefficients.copy()
        for j, value in enumerate((self.inertia, self.damping)):
            if value.is_fixed:
                draws[:, j] = value.median
        return draws

    @property
    def coefficient_covariance(self) -> np.ndarray:
        """Covariance of (m, b, amplitudes…), shape (2 + k, 2 + k): :attr:`covariance` without effects."""
        if not (self.effects or self.basis) or self.posterior is None:
            return self.covariance
        return np.atleast_2d(np.cov(self.coefficient_draws.T))

    def to_dict(self) -> dict:
        """JSON-ready (``identification`` of ``summary.json`` and ``posterior.json``)."""
        out = {"method": "given"} if self.given else self._fits_dict()
        if self.effects:
            out["effects"] = [e.to_dict() for e in self.effects]
        if self.expected_inertia is not None:
            out["inertia_in_expected_range"] = {"range": list(self.expected_inertia),
                                                "inside": self.inertia_in_expected_range}
        return out

    def _fits_dict(self) -> dict:
        ls, ml = self.least_squares, self.maximum_likelihood
        return {"method": self.method,
                "least_squares": {"inertia": ls.inertia, "damping": ls.damping, "window_s": ls.window,
                                  "condition": ls.condition},
                "maximum_likelihood": {"inertia": ml.inertia, "damping": ml.damping,
                                       "noise_levels": ml.noise.to_dict(), "loglik": ml.loglik},
                "noise_levels": self.noise_levels.to_dict(), "decimation": self.decimation,
                "angle_error": self.angle_error.to_dict(),
                "mcmc": self.posterior.diagnostics.to_dict(), "warnings": list(self.warnings)}


def identify_mechanics(filtered: Filtered, protocol: Protocol, *, rng: np.random.Generator, seed: int,
                       where: str = "trial", effects: EffectTerms | None = None,
                       basis: EffectTerms | None = None, fit: MechanicsFit | None = None) -> Identification:
    """Inertia and damping: the protocol's where given, else least squares → ML → emcee posterior.

    Parameters
    ----------
    filtered : Filtered
        The trial's signals (external variant).
    protocol : Protocol
        ``inertia``/``damping`` (given values), their priors and ``ci_level``.
    rng : numpy.random.Generator
        Source of every random draw of the posterior.
    seed : int
        Recorded in the MCMC diagnostics.
    where : str
        The trial's file, for error messages.
    effects : EffectTerms, optional
        Effects put in the model: their amplitudes are identified with m and b (also when m and
        b are given), and their uncertainty carried with them.
    basis : EffectTerms, optional
        The torques of the stiffness curve's weights (:mod:`limbstiff.scheduled`): linear
        coefficients like the effects' amplitudes, after them.
    fit : MechanicsFit, optional
        The maximum-likelihood fit of this very problem (the same signals, effects, curve and given
        m and b), when it was already made: the curve's resolution fits each candidate's.

    Returns
    -------
    Identification

    Raises
    ------
    TrialError
        When a posterior median is not positive (the data do not determine it).
    """
    m, b = protocol.inertia, protocol.damping
    given = (m, b) if m is not None and b is not None else None
    if given is not None and not effects and not basis:
        return Identification("given", Interval.fixed(m), Interval.fixed(b), np.zeros((2, 2)))
    decimation = kalman_decimation(filtered.sample_period, filtered.cutoff_hz)
    extra = [t.columns for t in (effects, basis) if t]
    problem, guess = mechanics_problem(filtered, given=given, extra=np.vstack(extra) if extra else None)
    fit = fit if fit is not None else kalman_mechanics(problem, guess=guess)
    post = sample(problem, start=fit, inertia_prior=protocol.inertia_prior, damping_prior=protocol.damping_prior,
                  rng=rng, seed=seed, given=given)
    effect = NO_EFFECT if given is not None else _angle_error(filtered, fit, guess, decimation, rng)
    post = _corrected(post, effect, problem, fit, filtered.motion_hz, rng)
    out, draws = _mechanics_intervals(post, (m, b), protocol.ci_level, where, reflex_hint=not effects)
    if effects or basis:
        # the least squares the checks compare with: on the torque less the effects (and the curve)
        # at their maximum-likelihood amplitudes (least squares alone has no term for them)
        guess = _least_squares(filtered, without_effects(filtered.torque, joined(effects, basis), fit.amplitudes))
    k = 0 if effects is None else len(effects)
    return Identification("given" if given is not None else "kalman+emcee", out[0], out[1], np.cov(draws.T),
                          least_squares=guess, maximum_likelihood=fit, posterior=post,
                          noise_levels=post.noise_levels(), decimation=decimation, warnings=tuple(post.warnings),
                          angle_error=effect, effects=effect_fits(effects, post.amplitudes[:, :k], protocol.ci_level),
                          basis=effect_fits(basis, post.amplitudes[:, k:], protocol.ci_level))


def _corrected(post: Posterior, effect: AngleErrorEffect, problem: MechanicsProblem, fit: MechanicsFit,
               motion_hz: float, rng: np.random.Generator) -> Posterior:
    """The posterior with the robust spread of m and b and, where it applies, the angle's error
    ``effect`` (else a warning saying why not)."""
    applied, refused = _angle_error_use(post, effect)
    post = _with_robust_spread(post, problem, fit, motion_hz,
                               effect.in_residual if applied else np.zeros((2, 2)), rng)
    return (_with_angle_error(post, effect, rng) if applied
            else dataclasses.replace(post, warnings=post.warnings + refused))


def mechanics_problem(filtered: Filtered, *, given: tuple[float, float] | None = None,
                      extra: np.ndarray | None = None) -> tuple[MechanicsProblem, LeastSquaresFit]:
    """The identification's problem on the filtered signals (``extra`` (k, n): effects' torques per
    unit amplitude; ``given`` (m, b) when they are not fitted), and the least-squares fit that
    sizes its noise bounds and starts its search."""
    guess = _least_squares(filtered, filtered.torque)
    problem = MechanicsProblem.build(filtered.angle, filtered.velocity, filtered.acceleration, filtered.torque,
                                     sample_period=filtered.sample_period,
                                     decimation=kalman_decimation(filtered.sample_period, filtered.cutoff_hz),
                                     motion_frequency=filtered.motion_hz, guess=guess, edge=filtered.edge,
                                     extra=extra, given=given)
    return problem, guess


def _least_squares(filtered: Filtered, torque: np.ndarray) -> LeastSquaresFit:
    """Windowed least squares of ``torque`` (n,) on the filtered signals, windows of
    :data:`IDENTIFY_PERIODS` motion periods."""
    return least_squares(torque, filtered.angle, filtered.velocity, filtered.acceleration,
                         sample_period=filtered.sample_period, window=IDENTIFY_PERIODS / filtered.motion_hz)


def _mechanics_intervals(post: Posterior, given, level: float, where: str, *,
                         reflex_hint: bool) -> tuple[list[Interval], np.ndarray]:
    """The intervals of m and b (fixed where ``given``) and their draws (n, 2).

    Raises
    ------
    TrialError
        When a posterior median is not positive; without effects in the model the message
        names a stretch reflex, which takes damping below zero when left out (a delayed
        velocity torque that resists motion less than in phase with it).
    """
    draws, out = post.mechanics.copy(), []
    for j, (name, value) in enumerate(zip(("inertia", "damping"), given)):
        if value is not None:
            draws[:, j] = value
            out.append(Interval.fixed(value))
            continue
        iv = Interval.of_draws(draws[:, j], level)
        if not iv.median > 0:
            hint = (" — or, if a stretch reflex may act, put it in the model with --effect reflex" if reflex_hint
                    else "")
            raise TrialError(where, f"{name} could not be identified (its posterior median is "
                                    f"{iv.median:.3g}); give it with --{name} or in the protocol{hint}")
        out.append(iv)
    return out, draws


def _angle_error(filtered: Filtered, fit: MechanicsFit, guess: LeastSquaresFit, decimation: int,
                 rng: np.random.Generator) -> AngleErrorEffect:
    """:func:`angle_error_effect` with (m, b) refitted at the maximum-likelihood noise levels, and
    the sandwich of each refit (the part of the sandwich the angle's error makes is its increase)."""
    logs = fit.noise.logs()

    def refit(angle):
        again = MechanicsProblem.build(angle[0], angle[1], angle[2], filtered.torque,
                                       sample_period=filtered.sample_period, decimation=decimation,
                                       motion_frequency=filtered.motion_hz, guess=guess, edge=filtered.edge)
        mean = again.conditional(logs)[1]
        return mean, robust_covariance(again, logs, mean, motion_frequency=filtered.motion_hz).sandwich
    return angle_error_effect(filtered, refit, rng=rng)


def _with_robust_spread(post: Posterior, problem: MechanicsProblem, fit: MechanicsFit, motion_frequency: float,
                        counted_elsewhere: np.ndarray, rng: np.random.Generator) -> Posterior:
    """The posterior draws of the coefficients (m, b, the effects' amplitudes) spread as the sandwich
    covariance says instead of the model's (:func:`robust_covariance` at the maximum-likelihood
    noise levels), with the sandwich's own error carried.

    The target is the sandwich less ``counted_elsewhere`` (the angle error's part of (m, b), whose
    spread is added by :func:`_with_angle_error`), its negative directions set to 0. The draws are
    mapped about their mean by T = S^½·L_model⁻¹ (S^½ the target's symmetric square root,
    L_model the model covariance's Cholesky factor), which takes one covariance to the other,
    then each scaled by a factor of the fixed-b limit of the Bartlett long-run variance
    (:mod:`limbstiff.mechanics.fixed_b`): their spread becomes a t distribution that is wider
    the larger the share of lags. Measured on 240 trials of ``benchmarks/identify.py``
    (``benchmarks/identify_intervals.py``, at 8d27b00): 3 motion periods of lags are a median
    share of 0.063–0.145 of the steps (wrists to ankles), and the ankles' intervals of m held the truth in
    81 % without the factors.
    """
    mean = np.concatenate([[fit.inertia, fit.damping][:problem.n_mechanics], fit.amplitudes])
    robust = robust_covariance(problem, fit.noise.logs(), mean, motion_frequency=motion_frequency)
    elsewhere = np.zeros_like(robust.sandwich)
    k = problem.n_mechanics
    elsewhere[:k, :k] = np.asarray(counted_elsewhere)[:k, :k]
    values, vectors = np.linalg.eigh(robust.sandwich - elsewhere)
    root = (vectors * np.sqrt(np.maximum(values, 0.0))) @ vectors.T
    try:
        t = root @ np.linalg.inv(np.linalg.cholesky(robust.model))
    except np.linalg.LinAlgError:
        return post
    coef = post.coefficients[:, 2 - k:]
    centre = coef.mean(axis=0)
    factors = bartlett_fixed_b(robust.lag_share).spread_factors(len(coef), rng)
    coef = centre + factors[:, None] * ((coef - centre) @ t.T)
    draws = post.draws.copy()
    draws[:, :k] = coef[:, :k]
    return dataclasses.replace(post, draws=draws, amplitudes=coef[:, k:])


def _angle_error_use(post: Posterior, effect: AngleErrorEffect) -> tuple[bool, tuple[str, ...]]:
    """Whether the angle error's shift and spread are applied (simulated, and a small shift), and
    the warning when a simulated one is too large to apply."""
    if effect.draws == 0 or not np.all(np.isfinite(effect.covariance)):
        return False, ()
    centre = np.abs(np.median(post.draws[:, :2], axis=0))
    if np.any(np.abs(effect.shift) > MAX_ANGLE_ERROR_SHIFT * centre):
        return False, (f"the angle's quantisation would move inertia and damping by {effect.shift[0]:.3g} and "
                       f"{effect.shift[1]:.3g}, more than {100 * MAX_ANGLE_ERROR_SHIFT:.0f} %: not a small error, "
                       "not corrected (a finer encoder or a given inertia and damping)",)
    return True, ()


def _with_angle_error(post: Posterior, effect: AngleErrorEffect, rng: np.random.Generator) -> Posterior:
    """The posterior draws of (m, b) less the angle error's shift, plus its spread (independent:
    the torque's noise and the angle's add)."""
    draws = post.draws.copy()
    spread = rng.multivariate_normal(np.zeros(2), effect.covariance, size=len(draws), method="eigh")
    draws[:, :2] += spread - effect.shift
    return dataclasses.replace(post, draws=draws)
