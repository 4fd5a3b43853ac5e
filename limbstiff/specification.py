"""The model of one analysis, specified once: which terms enter the torque besides m·ÿ + b·ẏ + s.

The effects the protocol puts in the model (:func:`limbstiff.effects.in_model.terms_for`) and, for
a curve analysis, the stiffness's curve over the cycle or a schedule
(:func:`limbstiff.scheduled.run.curve_terms`) are chosen from the data here, before the
identification; their coefficients are then read by name (:class:`~limbstiff.coefficients.Coefficients`).
The walk is estimated on the torque the spring is left to explain (:func:`spring_signals`), and the
stiffness course is the curve plus the walk (:func:`stiffness_course`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

from .coefficients import Coefficients
from .effects.in_model import filtered_without, terms_for
from .estimate.estimators import Estimate
from .filtered import Filtered
from .mechanics.effect_terms import EffectTerms, joined
from .protocol import Protocol
from .scheduled import run as scheduled
from .trial import Trial


@dataclass(frozen=True)
class ModelSpecification:
    """The linear terms of the model besides m and b.

    Parameters
    ----------
    effects : EffectTerms or None
        The effects in the model, at the shapes the data chose.
    curve : ScheduleTerms or None
        The stiffness's curve (a curve analysis), its resolution chosen by held-out prediction.
    """

    effects: EffectTerms | None = None
    curve: scheduled.ScheduleTerms | None = None

    @property
    def curve_terms(self) -> EffectTerms | None:
        """The curve's torques per unit weight (None without a curve, or for the walk alone)."""
        return None if self.curve is None else self.curve.terms

    @property
    def terms(self) -> EffectTerms | None:
        """Every term besides m and b, in the model's order: the effects, then the curve's weights."""
        return joined(self.effects, self.curve_terms)


def model_specification(trial: Trial, filtered: Filtered, protocol: Protocol,
                        prepared: scheduled.ScheduleInput | None, *, where: str) -> ModelSpecification:
    """The effects the protocol names at the shapes the data choose, and a curve analysis's curve."""
    effects = terms_for(trial, filtered, protocol, where=where)
    curve = None if prepared is None else scheduled.curve_terms(filtered, prepared, protocol, effects, where=where)
    return ModelSpecification(effects, curve)


def spring_signals(filtered: Filtered, spec: ModelSpecification, coefficients: Coefficients | None) -> Filtered:
    """The filtered signals with every term's torque at its identified coefficient taken off: what
    m, b and the spring are left to explain (``filtered`` itself without terms)."""
    terms = spec.terms
    if terms is None:
        return filtered
    return filtered_without(filtered, terms, coefficients.values_of(terms.names))


def stiffness_course(walk: Estimate, spec: ModelSpecification, coefficients: Coefficients | None) -> Estimate:
    """The stiffness course: the walk estimated on :func:`spring_signals` plus the curve at its
    weights, its sensitivity to each weight with it (the walk itself without a curve)."""
    terms = spec.curve_terms
    if terms is None:
        return walk
    return scheduled.with_curve(walk, spec.curve, coefficients)
