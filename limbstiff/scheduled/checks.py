"""Checks of a curve analysis: held-out cycles explained, cycles that disagree with the rest,
phases (or schedule values) without motion. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from ..checks.verdict import Check
from .curve import ScheduleCurve
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


def motion_check(curve: ScheduleCurve) -> Check:
    """``curve_coverage``: bins of the phase (or schedule) without enough informed samples."""
    empty = ~curve.informed
    share = float(empty.mean())
    if not empty.any():
        return Check("curve_coverage", 0.0, 0.0, True, f"every {curve.against} bin is informed by motion")
    runs, start = [], None
    for j, e in enumerate(np.append(empty, False)):
        if e and start is None:
            start = j
        elif not e and start is not None:
            runs.append((curve.edges[start], curve.edges[j]))
            start = None
    where = ", ".join(f"{a:.3g}–{b:.3g}" for a, b in runs[:6])
    unit = "" if curve.against == "phase" or curve.unit == "1" else f" {curve.unit}"
    return Check("curve_coverage", share, 0.0, False,
                 f"no stiffness at {curve.against} {where}{unit}: too little motion there in too few "
                 f"{'cycles' if curve.against == 'phase' else 'samples'} (perturb there, or record more)")
