"""A curve analysis inside :func:`limbstiff.analysis.analyze`: the calls it makes, in order.

:func:`schedule_input` prepares the trial; :func:`curve_terms` chooses the curve's resolution and
gives its torques (identified with m and b as linear coefficients); :func:`with_curve` adds the
curve to the walk's course; :func:`curve_analysis` pools the course into the curve, with its band
and checks. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks.verdict import Check
from ..errors import TrialError
from ..filtered import Filtered
from ..mechanics.effect_terms import EffectTerms
from ..statespace.linear import innovations
from .checks import disagree_check, heldout_check, motion_check, unit_errors
from .curve import ScheduleCurve, schedule_curve
from .fit import ScheduleTerms, schedule_terms, with_curve
from .prepare import ScheduleInput, perturbation_frequency, schedule_input
from .resolution import Resolution

#: Steps at the start of the record whose prediction errors are not compared: the filter starts
#: from its diffuse state there.
GUARD_STEPS = 20

__all__ = ["CurveAnalysis", "ScheduleInput", "curve_analysis", "curve_terms", "perturbation_frequency", "schedule_input", "with_curve"]


@dataclass(frozen=True)
class CurveAnalysis:
    """The stiffness against the phase or the schedule, how it was made, and its checks.

    Parameters
    ----------
    curve : ScheduleCurve
    resolution : Resolution
    prepared : dict
        How the cycles were cut or the schedule read (:meth:`ScheduleInput.to_dict`).
    checks : tuple of Check
    u : ndarray, shape (n,)
        The phase or the schedule at every sample of the (cropped) trial.
    """

    curve: ScheduleCurve
    resolution: Resolution
    prepared: dict
    checks: tuple[Check, ...]
    u: np.ndarray

    def binned(self, values: np.ndarray, informed: np.ndarray) -> np.ndarray:
        """The mean of ``values`` (n,) over the ``informed`` samples in each of the curve's bins
        (a reference stiffness on the curve's axis), NaN where a bin has none."""
        edges = self.curve.edges
        ok = informed & np.isfinite(self.u)
        which = np.clip(np.searchsorted(edges, self.u[ok], side="right") - 1, 0, len(edges) - 2)
        count = np.bincount(which, minlength=len(edges) - 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(which, weights=np.asarray(values)[ok], minlength=len(edges) - 1) / count

    @property
    def against(self) -> str:
        return self.curve.against

    def to_dict(self) -> dict:
        """JSON-ready (``by_phase`` / ``by_schedule`` of ``summary.json``)."""
        return {**self.curve.to_dict(), "resolution": self.resolution.to_dict(), **self.prepared}


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


def curve_analysis(prepared: ScheduleInput, terms: ScheduleTerms, estimate, ident, *, observable: np.ndarray,
                   stiffness: np.ndarray, level: float, seed: int) -> CurveAnalysis:
    """The curve pooled from the analysis's course, its band, and its checks."""
    curve = schedule_curve(estimate, ident, against=prepared.against, u=prepared.u, cycle=prepared.cycle,
                           observable=observable, stiffness=stiffness, level=level, unit=prepared.unit,
                           knots=terms.basis.knots, rng=np.random.default_rng([seed, 36]))
    noun = "cycles" if prepared.against == "phase" else "stretches"
    score = terms.resolution.score_of(terms.resolution.chosen)
    starts = None
    if prepared.cycle is not None:
        t = prepared.trial.time
        starts = np.array([t[np.flatnonzero(prepared.held_out == k)[0]] for k in range(prepared.n_cycles)])
    e, var = innovations(estimate.steps, estimate.fit.noise)
    unit = prepared.held_out[estimate.steps.index].copy()
    unit[:GUARD_STEPS] = -1                       # the filter's diffuse start
    errors = unit_errors(e[0], var, unit)
    checks = (heldout_check(score, noun=noun), disagree_check(errors, noun=noun, first_s=starts), motion_check(curve))
    return CurveAnalysis(curve, terms.resolution, prepared.to_dict(), checks, prepared.u)
