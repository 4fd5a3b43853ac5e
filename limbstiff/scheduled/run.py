"""A curve analysis inside :func:`limbstiff.analysis.analyze`: the calls it makes, in order.

:func:`schedule_input` prepares the trial; :func:`curve_terms` chooses the curve's resolution and
gives its torques (identified with m and b as linear coefficients); :func:`with_curve` adds the
curve to the walk's course; :func:`limbstiff.curve_result.curve_analysis` then pools the course
into the curve, with its band and checks (a result, above this maths). Pure numpy: no I/O.
"""

from __future__ import annotations

from ..errors import TrialError
from ..filtered import Filtered
from ..mechanics.effect_terms import EffectTerms
from .fit import ScheduleTerms, schedule_terms, with_curve
from .prepare import ScheduleInput, perturbation_frequency, schedule_input

__all__ = ["ScheduleInput", "curve_terms", "perturbation_frequency", "schedule_input", "with_curve"]


def curve_terms(filtered: Filtered, prepared: ScheduleInput, protocol, effects: EffectTerms | None, *,
                where: str) -> ScheduleTerms:
    """The curve's resolution and torques (:func:`~.fit.schedule_terms`); external variant and
    Kalman estimator only."""
    if filtered.variant != "external" or protocol.estimator != "kalman":
        raise TrialError(where, f"stiffness by {prepared.against} needs the external torque and the kalman "
                                "estimator (the curve's weights are identified with inertia and damping)")
    given = ((protocol.inertia, protocol.damping) if protocol.inertia is not None and protocol.damping is not None
             else None)
    return schedule_terms(filtered, prepared.against, prepared.u, prepared.held_out, unit=prepared.unit,
                          given=given, effects=effects)
