"""Checks of a curve analysis: held-out cycles explained, cycles that disagree with the rest,
phases (or schedule values) without motion; and the checks of whether its band can be trusted
(issue 46): the least-squares cross-check and a band wholly below zero. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from scipy.stats import binom, norm

from ..checks.verdict import UNRELIABLE, Check
from .curve import ScheduleCurve
from .least_squares import LeastSquaresCurve, effective_bins
from .resolution import ResolutionScore

#: Held-out units predicted with this much more error variance than the model expects of itself
#: (both in units of its own innovation variance S) fail: a curve that is not shared by the cycles
#: predicts the left-out ones worse than it fits them. A quarter is far beyond the sampling error
#: of a mean over thousands of steps (sd √(2/N) < 0.03 for N > 2000) and small against the errors
#: of a curve that misses a cycle's stiffness.
HELDOUT_ERROR_RATIO = 1.25
#: A unit whose held-out error stands this many robust standard deviations (1.4826·MAD) above the
#: units' median, and above :data:`DISAGREE_ERROR_RATIO` times it, disagrees with the rest.
DISAGREE_Z, DISAGREE_ERROR_RATIO = 5.0, 1.5
#: The least-squares cross-check fails when more bins disagree than chance allows at this level:
#: the upper tail of the binomial count of disagreeing bins (:func:`least_squares_check`).
CROSS_CHECK_ALPHA = 0.01


def heldout_check(score: ResolutionScore, *, noun: str) -> Check:
    """``curve_heldout``: the left-out units predicted about as well as the model fits."""
    ratio = score.heldout_error / score.model_error if score.model_error > 0 else float("nan")
    ok = not ratio > HELDOUT_ERROR_RATIO
    message = (f"left-out {noun} are predicted with {ratio:.2f}× the error the model has on all of them"
               + ("" if ok else f": the curve is not shared by the {noun} (more than "
                                 f"{HELDOUT_ERROR_RATIO:g}×); look at the {noun}' spread on the curve page"))
    return Check("curve_heldout", float(ratio), HELDOUT_ERROR_RATIO, ok, message)


def unit_errors(e: np.ndarray, var: np.ndarray, unit: np.ndarray) -> np.ndarray:
    """Each unit's mean squared one-step prediction error of the torque in units of its variance S
    (about 1 when the unit is like the model), from the final model's innovations ``e`` (m,) and
    ``var`` (m,) at steps of units ``unit`` (m,) (−1: none). Shape (U,)."""
    ok = unit >= 0
    n_units = int(unit.max()) + 1
    steps = np.bincount(unit[ok], minlength=n_units)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.bincount(unit[ok], weights=(e * e / var)[ok], minlength=n_units) / steps


def disagreeing(err: np.ndarray) -> np.ndarray:
    """The units (indices) whose error ``err`` (U,) stands out (:data:`DISAGREE_Z`)."""
    ok = np.isfinite(err)
    if ok.sum() < 5:
        return np.zeros(0, dtype=int)
    med = np.median(err[ok])
    mad = 1.4826 * np.median(np.abs(err[ok] - med)) or 1e-12
    z = (err - med) / mad
    return np.flatnonzero(ok & (z > DISAGREE_Z) & (err > DISAGREE_ERROR_RATIO * med))


def _one(noun: str) -> str:
    return {"cycles": "cycle", "stretches": "stretch"}.get(noun, noun)


def disagree_check(err: np.ndarray, *, noun: str, first_s: np.ndarray | None = None) -> Check:
    """``curve_outlier_units``: cycles (or stretches) whose torque the final model predicts far
    worse than the others' (:func:`unit_errors`), named by number and start."""
    bad = disagreeing(err)
    n = int(np.isfinite(err).sum())
    if not len(bad):
        return Check("curve_outlier_units", 0.0, 0.0, True, f"none of the {n} {noun} stands out from the others")
    names = ", ".join(f"{k + 1}" + ("" if first_s is None else f" (at {first_s[k]:.1f} s)") for k in bad[:8])
    more = "" if len(bad) <= 8 else f" and {len(bad) - 8} more"
    return Check("curve_outlier_units", float(len(bad)), 0.0, False,
                 f"{len(bad)} of {n} {noun} are predicted far worse than the others ({_one(noun)} {names}{more}): "
                 "an artefact, a different movement or a reflex in those; the curve pools them — look at them, "
                 "or leave them out")


def _where(curve: ScheduleCurve, mask: np.ndarray, most: int = 6) -> str:
    """The runs of bins ``mask`` (B,) as ``"phase 0.1–0.2, 0.5–0.56"`` (in the schedule's unit)."""
    runs, start = [], None
    for j, e in enumerate(np.append(mask, False)):
        if e and start is None:
            start = j
        elif not e and start is not None:
            runs.append((curve.edges[start], curve.edges[j]))
            start = None
    unit = "" if curve.against == "phase" or curve.unit == "1" else f" {curve.unit}"
    more = "" if len(runs) <= most else f" and {len(runs) - most} more stretches"
    return f"{curve.against} " + ", ".join(f"{a:.3g}–{b:.3g}" for a, b in runs[:most]) + unit + more


def chance_share(n: int, correlation: float, level: float) -> float:
    """The largest share of ``n`` compared bins that may disagree by chance.

    Two calibrated, independent Gaussian bands at ``level`` disagree beyond the root sum of their
    squared half-widths with probability 1 − ``level`` (the difference's own ``level`` band). Over
    :func:`effective_bins` independent comparisons, the share is that of the smallest count whose
    binomial upper tail is at most :data:`CROSS_CHECK_ALPHA`. Follows from the bands' definition,
    not fitted to trials.
    """
    n_eff = int(round(effective_bins(n, correlation)))
    k = int(binom.isf(CROSS_CHECK_ALPHA, n_eff, 1 - level)) + 1      # P(X ≥ k) ≤ alpha
    return k / n_eff


def _cross(curve: ScheduleCurve, ls: LeastSquaresCurve):
    """The compared bins, those that disagree, the chance share, and the mean standardised
    difference (curve − least squares, each band's half-width taken as z·σ) with its bound."""
    both = curve.informed & ls.informed
    hw_m, hw_ls = (curve.hi - curve.lo) / 2, (ls.hi - ls.lo) / 2
    apart = both & (np.abs(curve.stiffness - ls.stiffness) > np.hypot(hw_m, hw_ls))
    var_m, var_ls = np.median(hw_m[both] ** 2), np.median(hw_ls[both] ** 2)
    rho = (curve.adjacent_correlation * var_m + ls.adjacent_correlation * var_ls) / max(var_m + var_ls, 1e-300)
    n = int(both.sum())
    z = norm.isf((1 - curve.level) / 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = (curve.stiffness - ls.stiffness)[both] / np.maximum(np.hypot(hw_m, hw_ls)[both] / z, 1e-300)
    bound = norm.isf(CROSS_CHECK_ALPHA / 2) / np.sqrt(effective_bins(n, rho))
    return both, apart, chance_share(n, rho, curve.level), float(np.mean(d)), float(bound)


def least_squares_check(curve: ScheduleCurve, ls: LeastSquaresCurve) -> Check:
    """``curve_least_squares``: the curve against the least-squares fit in each bin where both are
    given. A bin disagrees when they differ by more than the root sum of squares of their
    half-widths; the check fails when more bins disagree than :func:`chance_share` allows, or when
    the curve lies on one side of the fit on average: the mean of the bins' differences in units of
    their combined σ beyond its :data:`CROSS_CHECK_ALPHA` two-sided bound over the
    :func:`effective_bins` (a level wrong everywhere, which correlated bins hide from the count)."""
    noun = "phase" if curve.against == "phase" else "schedule"
    if not (curve.informed & ls.informed).any():
        return Check("curve_least_squares", None, None, True,
                     f"no bin has both the curve and an informed least-squares fit by {noun}")
    both, apart, limit, mean_d, bound = _cross(curve, ls)
    n, k = int(both.sum()), int(apart.sum())
    share = k / n
    level_off = abs(mean_d) > bound
    if share < limit and not level_off:
        return Check("curve_least_squares", share, limit, True,
                     f"the least-squares fit by {noun} agrees with the curve within their bands in {n - k} of {n} bins "
                     f"(chance allows {100 * limit:.0f} % to disagree), and on average")
    ratio = float(np.median(curve.stiffness[both] / ls.stiffness[both]))
    where = (f"at {_where(curve, apart)}" if k else "everywhere a little")
    count = f"in {k} of {n} bins (chance allows {100 * limit:.0f} %) {where}"
    # lead with what failed: the count of bins, or the level (a count within chance then follows it)
    said = (f"disagree beyond their bands {count}" if share >= limit else
            f"differ in level: the curve lies {'below' if mean_d < 0 else 'above'} the fit on average (median "
            f"ratio {ratio:.2f}), beyond their bands {count}")
    if share >= limit and level_off:
        said += f"; the curve lies {'below' if mean_d < 0 else 'above'} the fit on average (median ratio {ratio:.2f})"
    return Check("curve_least_squares", share, limit, False,
                 f"the curve and a least-squares fit by {noun} (K, B and I of each bin's own) {said}: the model lacks "
                 "a feature of the data there (a sharp change, a reflex or a threshold it does not hold), so the "
                 "curve's band may not hold the stiffness there; the least-squares points are drawn on the curve's page")


def negative_check(curve: ScheduleCurve, ls: LeastSquaresCurve | None = None) -> Check:
    """``curve_negative``: bins whose band lies wholly below zero (``unreliable``): a limb is not
    negatively stiff, so the curve is wrong there whatever its band says."""
    below = curve.informed & (curve.hi < 0)
    if not below.any():
        return Check("curve_negative", 0.0, 0.0, True, "no bin's band lies wholly below zero", UNRELIABLE)
    said = ""
    if ls is not None and (ls.informed & below).any():
        k = ls.stiffness[ls.informed & below]
        said = f" (the least-squares fit gives {k.min():.3g} to {k.max():.3g} there)"
    return Check("curve_negative", float(below.sum()), 0.0, False,
                 f"the curve's own band (the model's, before the least-squares misfit is added) lies wholly below "
                 f"zero in {int(below.sum())} bins, at {_where(curve, below)}"
                 f"{said}: a negative stiffness, which a limb does not have — the model does not fit the data "
                 "there; do not use the curve at those values", UNRELIABLE)


def motion_check(curve: ScheduleCurve) -> Check:
    """``curve_coverage``: bins of the phase (or schedule) without enough informed samples."""
    empty = ~curve.informed
    share = float(empty.mean())
    if not empty.any():
        return Check("curve_coverage", 0.0, 0.0, True, f"every {curve.against} bin is informed by motion")
    return Check("curve_coverage", share, 0.0, False,
                 f"no stiffness at {_where(curve, empty)}: too little motion there in too few "
                 f"{'cycles' if curve.against == 'phase' else 'samples'} (perturb there, or record more)")
