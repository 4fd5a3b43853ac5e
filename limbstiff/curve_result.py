"""The stiffness curve of an analysis as a result: :class:`CurveAnalysis` and how it is made.

:func:`curve_analysis` pools the analysis's course into the curve against the cycle's phase or a
recorded schedule (:func:`limbstiff.scheduled.curve.schedule_curve`), with its band, its checks,
the least-squares cross-check (:mod:`limbstiff.scheduled.least_squares`) and its own verdict: the
worst of the trial's verdict (the curve is the trial's course pooled, so every reason of the trial
concerns it) and of the checks of whether its band can be trusted (``curve_least_squares``,
``curve_negative``: these concern the curve alone and do not change the trial's verdict).
The result answers the protocol every result of the package answers: ``to_dict()`` (the
``by_phase`` / ``by_schedule`` block of ``summary.json``), ``to_frame()``
(``stiffness_by_phase.csv`` / ``stiffness_by_schedule.csv``), ``plot(ax=…)`` and ``report()``. It
lives above the maths of :mod:`limbstiff.scheduled` (which draws nothing) so that its ``plot`` may
hand off to :func:`limbstiff.report.curve.plot_curve`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .checks.verdict import Check, ModelChecks, Verdict
from .coefficients import Coefficients
from .files.outputs import jsonable
from .scheduled.checks import (disagree_check, heldout_check, least_squares_check, motion_check, negative_check,
                               unit_errors)
from .scheduled.curve import ScheduleCurve, interpolation_error, schedule_curve
from .scheduled.least_squares import LeastSquaresCurve, curve_least_squares, misfit_share
from .scheduled.fit import ScheduleTerms
from .scheduled.prepare import ScheduleInput
from .scheduled.resolution import Resolution
from .statespace.linear import innovations

#: Steps at the start of the record whose prediction errors are not compared: the filter starts
#: from its diffuse state there.
GUARD_STEPS = 20

__all__ = ["CurveAnalysis", "curve_analysis"]


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
        The curve's checks that are the trial's too (``curve_heldout``, ``curve_outlier_units``,
        ``curve_coverage``).
    u : ndarray, shape (n,)
        The phase or the schedule at every sample of the (cropped) trial.
    least_squares : LeastSquaresCurve or None
        The least-squares cross-check by bin.
    band_checks : tuple of Check
        Whether the curve's band can be trusted (``curve_least_squares``, ``curve_negative``): the
        curve's verdict only.
    trial_checks : ModelChecks or None
        The trial's checks (set by the analysis once they are final).
    """

    curve: ScheduleCurve
    resolution: Resolution
    prepared: dict
    checks: tuple[Check, ...]
    u: np.ndarray
    least_squares: LeastSquaresCurve | None = None
    band_checks: tuple[Check, ...] = ()
    trial_checks: ModelChecks | None = None

    @property
    def verdict(self) -> Verdict:
        """The curve's own verdict: the worst of the trial's and of its :attr:`band_checks`."""
        trial = self.trial_checks.verdict if self.trial_checks is not None else Verdict.worst(
            c.severity for c in self.checks if not c.passed)
        return Verdict.worst([trial, *(c.severity for c in self.band_checks if not c.passed)])

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why the curve is not ``ok``: its band checks' messages (the most severe first), then the
        trial's reasons, the curve's own checks among them first."""
        own = [c for c in (*self.band_checks, *self.checks) if not c.passed]
        first = [c.message for c in sorted(own, key=lambda c: -c.severity.code)]
        trial = self.trial_checks.reasons if self.trial_checks is not None else ()
        return tuple(first + [r for r in trial if r not in first])

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

    @property
    def pooled_over(self) -> str:
        """What the curve is pooled over, in words: ``"12 cycles (every 1.5 s from 0 s)"``, or the
        schedule's column."""
        if self.against != "phase":
            return str(self.prepared.get("how"))
        return f"{self.prepared.get('n_cycles')} cycles ({self.prepared.get('how')})"

    @property
    def task_cycle_s(self) -> str | None:
        """The length of the task's cycles in words (``"1.5 s"``, ``"0.95–1.1 s"`` when they differ),
        None for a schedule."""
        lengths = self.prepared.get("cycle_length_s")
        if not lengths:
            return None
        lo, hi = lengths["min"], lengths["max"]
        return f"{lengths['median']:.3g} s" if f"{lo:.2g}" == f"{hi:.2g}" else f"{lo:.2g}–{hi:.2g} s"

    def to_dict(self) -> dict:
        """JSON-ready (``by_phase`` / ``by_schedule`` of ``summary.json``)."""
        ls = None if self.least_squares is None else self.least_squares.to_dict()
        return jsonable({**self.curve.to_dict(), "resolution": self.resolution.to_dict(), **self.prepared,
                         "verdict": self.verdict, "reasons": list(self.reasons),
                         "checks": [c.to_dict() for c in (*self.checks, *self.band_checks)], "least_squares": ls})

    def to_frame(self):
        """The curve's table (``stiffness_by_phase.csv`` / ``stiffness_by_schedule.csv``) as a
        :class:`pandas.DataFrame` (:meth:`ScheduleCurve.to_frame`), with the least-squares
        cross-check's ``ls_stiffness``, ``ls_stiffness_lo``, ``ls_stiffness_hi`` (N·m/rad; blank
        where it is not informed)."""
        frame = self.curve.to_frame()
        if self.least_squares is not None:
            ls = self.least_squares
            frame = frame.assign(ls_stiffness=ls.stiffness, ls_stiffness_lo=ls.lo, ls_stiffness_hi=ls.hi)
        return frame

    def plot(self, ax=None, *, unit_stiffness: str = "N·m/rad", legend: bool = True):
        """Draw the curve, its band, (ensembles) the cycles' spread and the least-squares points into a matplotlib axes
        (:func:`limbstiff.report.curve.plot_curve`); pyplot's current axes when ``ax`` is omitted.

        Returns
        -------
        matplotlib.axes.Axes
        """
        from .report.curve import plot_curve
        return plot_curve(self.curve, ax=ax, unit_stiffness=unit_stiffness, legend=legend,
                          least_squares=self.least_squares)

    def report(self, *, unit_stiffness: str = "N·m/rad") -> str:
        """The curve in words: its verdict and reasons, what it is pooled over, its resolution, its
        median and range over the informed bins."""
        from .digest import number
        d, res = self.curve.to_dict(), self.resolution
        units = "cycles" if self.against == "phase" else "stretches"
        over = self.pooled_over
        knots = (f"{res.chosen} knots" if res.chosen
                 else f"none finer than the walk (no curve predicted left-out {units} better)")
        level = f"{d['informed_bins']} of {d['bins']} bins informed"
        figures = ("no bin is informed" if d["median"] is None else
                   f"median {number(d['median'], unit_stiffness)}, from {number(d['min'])} to "
                   f"{number(d['max'], unit_stiffness)} ({level})")
        lines = [f"Curve verdict: {self.verdict}" + ("" if self.reasons else " (its checks and the least-squares "
                                                                         "cross-check pass)")]
        lines += [f"  - {r}" for r in self.reasons]
        lines += [f"Stiffness by {'phase of the cycle' if self.against == 'phase' else 'schedule'}, pooled over "
                  f"{over}: {figures}.", f"Resolution: {knots}, chosen by predicting left-out {units}."]
        return "\n".join(lines)


def curve_analysis(prepared: ScheduleInput, terms: ScheduleTerms, estimate, ident, *, filtered,
                   observable: np.ndarray, stiffness: np.ndarray, level: float, seed: int) -> CurveAnalysis:
    """The curve pooled from the analysis's course, its band, its checks and the least-squares
    cross-check on the analysis's ``filtered`` signals."""
    curve = schedule_curve(estimate, ident, against=prepared.against, u=prepared.u, cycle=prepared.cycle,
                           units=prepared.held_out, observable=observable, stiffness=stiffness, level=level,
                           unit=prepared.unit, knots=terms.basis.knots, rng=np.random.default_rng([seed, 36]))
    ls = curve_least_squares(filtered, prepared, curve.edges, observable, level=level,
                             rng=np.random.default_rng([seed, 46]))
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
    # the cross-check judges the curve's own band; the band published also holds the misfit it measures
    band_checks = (least_squares_check(curve, ls), negative_check(curve, ls))
    weights = terms.weights(None if ident is None else Coefficients.of(ident))
    interpolation = interpolation_error(terms.basis, weights, curve.edges)
    return CurveAnalysis(curve.widened(misfit_share(curve, ls), interpolation), terms.resolution, prepared.to_dict(),
                         checks, prepared.u, ls, band_checks)
