"""The stiffness's curve in the analysis's model: its resolution chosen, its columns, and the
course with the curve added back.

The curve's weights are identified like an effect's amplitudes
(:func:`~limbstiff.mechanics.identification.identify_mechanics`, ``basis=``); their torques are
taken off the torque with the effects' before the Kalman estimate, so the estimator's course is
the walk alone. :func:`with_curve` adds the curve back: σ(t) = walk(t) + Σ_j β_j·h_j(u(t)), whose
response to β_j is the walk's response plus h_j(u(t)) — the estimate stays affine in every
coefficient, and the band carries the weights' posterior with m's and b's. Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..estimate.estimators import Estimate
from ..filtered import Filtered
from ..mechanics.effect_terms import EffectTerms
from .basis import PHASE_KNOTS, SCHEDULE_KNOTS, StiffnessBasis, phase_basis, schedule_basis
from .resolution import Resolution, choose_resolution

#: A resolution needs at least this many Kalman steps per knot: finer knots hold too little data
#: to be judged.
MIN_STEPS_PER_KNOT = 50


@dataclass(frozen=True)
class ScheduleTerms:
    """The curve put in the model.

    Parameters
    ----------
    basis : StiffnessBasis
        At the chosen resolution.
    resolution : Resolution
        The resolutions tried, their held-out scores.
    u : ndarray, shape (n,)
        The phase or the schedule at every sample.
    terms : EffectTerms or None
        Its torques per unit weight (none for the walk alone).
    """

    basis: StiffnessBasis
    resolution: Resolution
    u: np.ndarray
    terms: EffectTerms | None

    @property
    def fit(self):
        """The chosen model's maximum-likelihood fit (:class:`~limbstiff.mechanics.likelihood.MechanicsFit`),
        made while choosing the resolution: the identification starts from it."""
        return self.resolution.score_of(self.resolution.chosen).fit

    @property
    def weight_names(self) -> tuple[str, ...]:
        """The coefficients of the stiffness's own weights (J − 1; after them in :attr:`terms`, the
        gains of effects modulated over the cycle)."""
        return () if self.terms is None else self.terms.names[:self.basis.size]

    def weights(self, coefficients) -> np.ndarray:
        """The curve's weights, the values of :attr:`weight_names` among ``coefficients``
        (:class:`~limbstiff.coefficients.Coefficients`), shape (J − 1,), N·m/rad; zeros where no
        curve was identified (no terms, or no coefficients)."""
        if coefficients is None or not self.weight_names:
            return np.zeros(self.basis.size)
        return coefficients.values_of(self.weight_names)


def candidates(against: str, u: np.ndarray, *, n_steps: int, unit: str) -> dict[int, StiffnessBasis]:
    """The resolutions worth trying (:data:`~.basis.PHASE_KNOTS` or :data:`~.basis.SCHEDULE_KNOTS`),
    with at least :data:`MIN_STEPS_PER_KNOT` steps per knot."""
    knots = PHASE_KNOTS if against == "phase" else SCHEDULE_KNOTS
    knots = [k for k in knots if k == 0 or n_steps / k >= MIN_STEPS_PER_KNOT]
    if against == "phase":
        return {k: phase_basis(k) for k in knots}
    return {k: schedule_basis(k, u, unit=unit) for k in knots}


def curve_columns(basis: StiffnessBasis, u: np.ndarray, filtered: Filtered,
                  modulated: EffectTerms | None = None) -> np.ndarray | None:
    """The torques per unit weight of the curve (J − 1, n) (:meth:`StiffnessBasis.columns`), then,
    on the phase, each effect's torque times each weight's function (k·(J − 1), n): an effect in the
    model (a reflex) whose gain changes over the cycle like the stiffness. None for the walk alone."""
    if not basis.size:
        return None
    cols = basis.columns(u, filtered.angle, sample_period=filtered.sample_period, motion_frequency=filtered.motion_hz)
    if modulated is None or not len(modulated) or not basis.periodic:
        return cols
    design = np.where(np.isfinite(basis.design(u)), basis.design(u), 0.0)
    gains = (modulated.columns[:, None, :] * design[None, :, :]).reshape(-1, len(u))
    return np.ascontiguousarray(np.vstack([cols, gains]))


def schedule_terms(filtered: Filtered, against: str, u: np.ndarray, unit_of_sample: np.ndarray, *, unit: str,
                   given: tuple[float, float] | None, effects: EffectTerms | None) -> ScheduleTerms:
    """The curve's resolution chosen by held-out prediction (:func:`choose_resolution`) and its
    torques per unit weight at the samples (:func:`curve_columns`: on the phase, the effects' gains
    change over the cycle with the stiffness)."""
    from ..statespace.steps import kalman_decimation

    n_steps = len(filtered.angle) // kalman_decimation(filtered.sample_period, filtered.cutoff_hz)
    bases = candidates(against, u, n_steps=n_steps, unit=unit)

    def columns(basis):
        return curve_columns(basis, u, filtered, effects)

    resolution = choose_resolution(filtered, bases, columns, unit_of_sample, given=given,
                                   effect_columns=None if effects is None else effects.columns)
    basis = bases[resolution.chosen]
    cols = columns(basis)
    if cols is None:
        return ScheduleTerms(basis, resolution, u, None)
    knots = basis.knots[1:]
    names = [f"stiffness_at_{against}_knot_{j}" for j in range(1, len(basis.knots))]
    shapes = [{"knot": float(k)} for k in knots]
    amplitudes, units = ["stiffness_step"] * basis.size, ["N·m/rad"] * basis.size
    for e in range(len(cols) // basis.size - 1):
        names += [f"{effects.names[e]}_{effects.amplitude_names[e]}_at_{against}_knot_{j}" for j in range(1, len(basis.knots))]
        shapes += [{"knot": float(k)} for k in knots]
        amplitudes += [f"{effects.amplitude_names[e]}_step"] * basis.size
        units += [effects.units[e]] * basis.size
    terms = EffectTerms(names=tuple(names), shapes=tuple(shapes), amplitude_names=tuple(amplitudes),
                        units=tuple(units), columns=cols)
    return ScheduleTerms(basis, resolution, u, terms)


def with_curve(estimate: Estimate, schedule: ScheduleTerms, coefficients) -> Estimate:
    """The estimate of the walk with the curve at its weights among ``coefficients``
    (:meth:`ScheduleTerms.weights`) added back, and its response to each (the sensitivity's rows
    where :attr:`ScheduleTerms.weight_names` stand among the model's coefficients)."""
    if schedule.terms is None:
        return estimate
    design = schedule.basis.design(schedule.u)
    design = np.where(np.isfinite(design), design, 0.0)
    sens = estimate.sensitivity.copy()
    sens[coefficients.positions(schedule.weight_names)] += design
    return dataclasses.replace(estimate, stiffness=estimate.stiffness + schedule.weights(coefficients) @ design,
                               sensitivity=sens)
