"""The trial-level figures over joint posterior draws of the stiffness course.

The figures (:mod:`limbstiff.trial_level`) are taken at the Kalman model's steps, whichever
estimator ran; their intervals come from joint draws of the course: its posterior
(:func:`~limbstiff.estimate.course_draws.course_deviations`), the model's coefficients drawn
through the estimate's sensitivity to them, the stiffness's change with the angle within the
cycle, and the alternatives to the chosen model (:class:`~limbstiff.band.ModelForm`). Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .band import ModelForm
from .checks.verdict import ANGLE_WALD
from .coefficients import Coefficients
from .estimate.angle_terms import AngleTerms
from .estimate.course_draws import course_deviations
from .estimate.estimators import Estimate
from .filtered import Filtered
from .statespace.steps import kalman_decimation, step_index
from .trial_level import FigureSamples, TrialLevel, course_draws_for, figure_samples, trial_level


def figure_samples_of(filtered: Filtered, observable: np.ndarray) -> FigureSamples:
    """The samples of a trial's figures: the Kalman model's steps (whichever estimator ran), thinned."""
    decimation = kalman_decimation(filtered.sample_period, filtered.cutoff_hz)
    steps = step_index(len(filtered.angle), edge=filtered.edge, decimation=decimation)
    return figure_samples(steps, filtered.torque, observable, step=filtered.sample_period * decimation,
                          motion_frequency=filtered.motion_hz)


def trial_level_figures(filtered: Filtered, estimate: Estimate, coefficients: Coefficients | None,
                        observable: np.ndarray, *, limb, level: float, seed: int,
                        angle: AngleTerms | None = None, form: ModelForm | None = None) -> TrialLevel:
    """The trial-level figures over joint draws of the course at the Kalman model's steps.

    The draws are the course's posterior (:func:`course_deviations`) plus posterior draws of the
    model's coefficients through the estimate's sensitivity, on the informed steps; with ``angle``
    (:func:`told_angle`) the stiffness's change with the angle within the cycle, drawn too.

    Parameters
    ----------
    filtered : Filtered
    estimate : Estimate
        The estimator's output; its steps and sensitivity, when it has them, give the draws.
    coefficients : Coefficients or None
        The model's linear coefficients (m, b, the effects' amplitudes…) with their posterior
        draws; None when m and b are not in the model (direct variant).
    observable : ndarray of bool, shape (n,)
        The samples informed by motion.
    limb : callable
        Maps a one-body stiffness (an array of any shape) to the limb's, N·m/rad (N/m).
    level, seed : float, int
        Level of the intervals (0.9 for 90 %), seed of the draws.
    angle : AngleTerms, optional
        The stiffness's change with the angle within the cycle.
    form : ModelForm, optional
        Alternatives to the chosen model, each draw's drawn with its weight.

    Returns
    -------
    TrialLevel
        Its intervals are NaN when there is nothing to draw (no joint uncertainty).
    """
    angle = told_angle(angle)
    samples, base = figure_course(filtered, estimate, observable, angle=angle)
    rng = np.random.default_rng([seed, 14])
    n_draws = course_draws_for(len(samples.index) if estimate.steps is None else len(estimate.steps.index))
    draws, sources = np.repeat(estimate.stiffness[samples.index][None, :], n_draws, axis=0), []
    if estimate.steps is not None:
        draws += course_deviations(estimate.steps, estimate.fit.noise, draws=n_draws, rng=rng,
                                   columns=samples.columns)
        sources.append("course")
    if angle is not None:
        missed = angle.missed[:, samples.columns]
        draws += rng.multivariate_normal(angle.coefficients, angle.covariance, n_draws) @ missed
        sources.append("angle")
    if coefficients is not None and coefficients.draws is not None and estimate.sensitivity is not None:
        coef = coefficients.draws[rng.integers(0, len(coefficients.draws), n_draws)]
        draws += (coef - coefficients.values) @ coefficients.rows_of(estimate.sensitivity)[:, samples.index]
        sources.append("mechanics")
    if form is not None and sources:
        draws += form.draws(rng, n_draws, samples.index)
        sources.append("model form")
    if not sources:
        draws = np.full_like(draws, np.nan)           # no joint uncertainty: no interval claimed
    informed = samples.informed
    course = limb(base)
    return dataclasses.replace(trial_level(course[informed], limb(draws)[:, informed], samples.torque[informed],
                                           level=level, sources=tuple(sources)),
                               course=course, index=samples.index, informed=informed)


def told_angle(angle: AngleTerms | None) -> AngleTerms | None:
    """The angle terms when the data tell their change from noise (their Wald statistic beyond
    :data:`~limbstiff.checks.verdict.ANGLE_WALD`, as the ``angle_dependence`` check reads them), None
    otherwise: a change the check calls noise is not added to the figures (on the constant stiffness
    of ``benchmarks/reflex_study.py``'s clean trials it shifted the median's interval off the truth:
    issue 46)."""
    return angle if angle is not None and angle.wald > ANGLE_WALD else None


def figure_course(filtered: Filtered, estimate: Estimate, observable: np.ndarray, *,
                  angle: AngleTerms | None = None) -> tuple[FigureSamples, np.ndarray]:
    """The one-body course the trial-level figures are taken over: the estimate at the figure's
    samples (:func:`figure_samples_of`), with the stiffness's change with the angle within the cycle
    that the smoothed course misses (:meth:`AngleTerms.missed_course`) when ``angle`` is given and
    :func:`told_angle`.
    The analysis's median stiffness is the median of its limb's value over the informed samples;
    the diagnosis's stiffness with an effect removed is taken the same way.

    Returns
    -------
    samples : FigureSamples
    course : ndarray, shape (c,), N·m/rad (N/m)
    """
    samples = figure_samples_of(filtered, observable)
    base = estimate.stiffness[samples.index]
    angle = told_angle(angle)
    if angle is not None:
        base = base + angle.coefficients @ angle.missed[:, samples.columns]
    return samples, base
