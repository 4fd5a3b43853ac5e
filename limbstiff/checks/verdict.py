"""The model checks of one analysis, and the verdict they give.

Each check compares one statistic with a threshold and, when it fails, says in plain words what
it means and what to do. The verdict is the worst severity among the failed checks: ``ok`` (the
model fits: use the numbers), ``caution`` (the model misses part of the recording: the numbers
may be biased) or ``unreliable`` (do not use the stiffness).

The thresholds were set on simulated trials (elbow, wrist and ankle, clean and with each of the
simulator's ten effects; seeds other than the benchmark's) and on the five real ankle trials
(``data/reklab-ankle``), so that clean trials and the trials the model fits (z_df,
z_df3, whose stiffness matches the least-squares reference of SOURCE.md) pass while the trial
the model does not fit (z_pf: a quarter of its stiffness negative) fails. The angle-dependence
check, added later, was not tuned on these: it flags z_df and z_df2, whose stiffness changes with
the angle within the perturbation (:data:`ANGLE_WALD` and the constants after it). The figures behind
each are in the constants' comments; ``benchmarks/checks.py`` measures the false-alarm and
detection rates on other seeds.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Iterable

import numpy as np


class Verdict(StrEnum):
    """What the checks say of a stiffness, offline and live: a string (``"ok"``…, as written to
    JSON and CSV) with its severity :attr:`code`, the number a live stream publishes."""

    OK = "ok"
    CAUTION = "caution"
    UNRELIABLE = "unreliable"

    @property
    def code(self) -> int:
        """0 (ok), 1 (caution) or 2 (unreliable): the severity, the larger the worse."""
        return _CODES[self]

    @classmethod
    def worst(cls, verdicts: Iterable["Verdict"]) -> "Verdict":
        """The most severe of ``verdicts``; ``ok`` when there are none."""
        return max(verdicts, key=lambda v: v.code, default=cls.OK)


_CODES = {Verdict.OK: 0, Verdict.CAUTION: 1, Verdict.UNRELIABLE: 2}
OK, CAUTION, UNRELIABLE = Verdict.OK, Verdict.CAUTION, Verdict.UNRELIABLE
#: The code a live stream publishes while it has no estimate (warming up), beside :attr:`Verdict.code`.
NO_ESTIMATE = -1

#: Share of the samples informed by motion below which the analysis warns that the motion informs too
#: little of the trial, and the live verdict is ``caution``: half the trial without an estimate of its own.
MOTION_MIN = 0.5
#: Held-out share of the torque explained below which the verdict is ``caution``, and
#: ``unreliable``. Clean simulated trials: 0.99–1.00; simulated effects that bias the stiffness
#: 5–35 %: 0.84–0.96; real trials the model fits: 0.68 (z_df), 0.74 (z_df3), 0.84 (z_df2); the
#: plantarflexor trials with a large reflex: 0.31 (z_pf2), 0.03 (z_pf).
HELDOUT_CAUTION, HELDOUT_UNRELIABLE = 0.5, 0.2
#: Largest |autocorrelation| of the standardised innovations (lags 1–10 steps). Low-passed noise
#: is correlated from step to step even when the model is right: clean simulated trials reach
#: 0.39, the real trials 0.46–0.58 (a stretch reflex); 0.8 is left for torque the model cannot
#: follow at all (a resonance, a lost channel).
WHITENESS_MAX = 0.8
#: Largest |correlation| of the innovations with the velocity they follow by 0–100 ms. Clean
#: simulated trials: ≤ 0.18; a simulated reflex: 0.45; the real dorsiflexor trials (a small
#: reflex, stiffness within the reference's ±20–30 %): 0.30–0.42.
VELOCITY_CORRELATION_MAX = 0.5
#: Share of the informed samples with a negative stiffness above which it is ``unreliable``:
#: a limb or a spring is not negatively stiff; 5 % leaves room for the band's own spread near
#: zero. Every clean and effect trial: 0; z_pf: 0.24.
NEGATIVE_SHARE_MAX = 0.05
#: Share of the stiffness by which the stiffness may be off and the model still be said to fit it,
#: and share beyond which it is wrong (the definitions of ``benchmarks/checks.py``, FITS and WRONG).
FITS, WRONG = 0.10, 0.20
#: Median band width over |median stiffness| above which it is ``caution``: the band itself says
#: the stiffness is not known to within :data:`FITS`. For a calibrated Gaussian 90 % band of
#: relative width w the median relative error is Φ⁻¹(0.75)/Φ⁻¹(0.95)·w/2 = 0.205·w, which exceeds
#: FITS for w > 2·FITS·1.645/0.674 = 0.49. Follows from the band's definition, not fitted to trials.
#: (It was 1.0, "the band wider than the stiffness", a median error of 20 % expected; measured then:
#: clean ≤ 0.06, effects ≤ 0.9, z_pf2 1.3, z_pf 5.6. The simulated platform ankle with hysteresis
#: sat below it, band 0.87–0.91 wide on seeds 101–102, 33 % off.)
#: Measured on seeds 101–102 and suite seeds 7100, 7200 (not the benchmark's): clean trials ≤ 0.35
#: (the independent gait ankle, 9 % off; limbstiff's own ≤ 0.12); the real ankles z_df, z_df2,
#: z_df3 0.06, 0.24, 0.32, z_pf2 0.53, z_pf 1.8.
BAND_WIDTH_MAX = 2 * FITS * 1.6449 / 0.6745
#: Median band width over |median stiffness| above which it is ``unreliable``: a 90 % band more
#: than twice as wide as the stiffness reaches zero (half-width > |median|), so the recording does
#: not tell a stiffness from none. Follows from the band's definition, not fitted to trials.
BAND_ZERO_MAX = 2.0
#: A noise level less than this (natural-log units, a factor 1.65) below its upper bound is "at
#: the bound". For the stiffness walk that means the stiffness changes as fast as the model
#: allows, taking up torque it does not explain: clean simulated trials stay ≥ 5 below it, z_df
#: and z_df3 ≥ 4, while z_pf, z_pf2 and the simulated ankle with quadratic damping or hysteresis
#: sit on it. The torque walk on its bound is usual on real data (it holds the reflex torque)
#: and is reported without failing.
BOUND_MARGIN = 0.5
#: Largest relative change of the stiffness that the least-squares or maximum-likelihood m and b
#: would make in place of the posterior's (the stiffness is read from the elastic torque's increments
#: over the angle's, so a different m·ÿ + b·ẏ moves it by the slope of its increments on the angle's):
#: beyond :data:`WRONG` which estimate of m and b is right decides whether the stiffness is right. A
#: relative disagreement on m or b alone (0.2 before; measured then: clean ≤ 0.02, z_df 0.14, simulated
#: backlash 0.21–0.26, z_pf2 0.27, z_pf 0.54) flags parameters that matter little to the
#: stiffness: the independent simulator's clean gait ankle and actuator disagreed by 29–50 % on m
#: and moved the stiffness by 2–3 % (suite seeds 7100, 7200). Measured on seeds 101–102: clean
#: trials ≤ 0.02; simulated ankle backlash (22–30 % off) 0.33 and 0.67; the coupled ankle with
#: quadratic damping (49 % off) 0.58; the real ankles z_df, z_df2, z_df3 0.04, z_pf2 0.16, z_pf 0.67.
AGREEMENT_MAX = WRONG
#: Measurement noise below this share of the torque's variance above half the motion frequency
#: (an innovation of 1 % of that spread) leaves a residual too small for its structure to matter: the whiteness,
#: velocity-correlation and noise-bound checks then pass. Noise-free simulations (the paper's
#: scenarios) sit at 10⁻⁶, where the residual is the integration's own error; the simulated limbs
#: (2·10⁻⁴–2·10⁻³) and the real ankle (6·10⁻² on z_df) are checked.
NEGLIGIBLE_RESIDUAL = 1e-4
#: … and only where the model is shown to predict at least this share of the torque out of sample
#: (a trial too short to hold out whole periods is judged):
#: the noise-free paper scenarios do (0.99–1.00); a nearly noise-free platform with a stretch
#: reflex does not (0.954–0.958, stiffness 25–56 % off), and its residual's structure then counts.
NEGLIGIBLE_HELDOUT = 0.99
#: Wald statistic of the angle terms (χ² with 2 degrees of freedom, sandwich covariance) above which
#: the stiffness is taken to change with the angle within the cycle: the upper 0.1 % point, which a
#: stiffness that does not depend on the angle would exceed in 1 trial in 1000 were the sandwich
#: exact. Not fitted to trials. Measured: limbstiff's simulated limbs without an angle-dependent
#: spring 0.1–5.7 (the accuracy benchmark's 14 such trials; its angle-dependent elbow 14 and 22),
#: but 19 on one clean 20 s ankle of the checks benchmark (the sandwich is not exact there: see
#: ANGLE_CHANGE_MIN); the independent simulator's constant, ramp and pause elbows 0.3–8.2 (12
#: trials), its actuators (antagonistic nonlinear springs) 4–20, its cubic springs 98–317.
ANGLE_WALD = 13.8155
#: … and the fitted variation (rms over the informed samples) must exceed this many half-widths of
#: the band (its median), so that the band does not hold the stiffness at the cycle's extremes.
#: Follows from the band's definition, not fitted to trials.
ANGLE_VARIATION_MAX = 1.0
#: … and exceed this share of the stiffness: a change within the cycle smaller than 1 % of the
#: stiffness is below what a study of joint stiffness resolves (trial-to-trial spreads are several
#: per cent), however narrow the band. Measured: a clean simulated ankle (band ±0.1 %) failed
#: without it at ±0.3 % (Wald 19, 1 of its 5 seeds in the checks benchmark); the flagged trials of
#: the independent simulator change by 5–17 %, the real ankles z_df and z_df2 by 11 % and 14 %.
ANGLE_CHANGE_MIN = 0.01


@dataclass(frozen=True)
class Check:
    """One model check.

    Parameters
    ----------
    name : str
    value : float or None
        The statistic (None when it could not be computed; the check then passes).
    threshold : float or None
    passed : bool
    message : str
        What the value means, in plain words, and what to do when it failed.
    severity : Verdict or str
        The verdict the check gives when it fails (``caution`` or ``unreliable``; a string is taken as
        its :class:`Verdict`).
    """

    name: str
    value: float | None
    threshold: float | None
    passed: bool
    message: str
    severity: Verdict = CAUTION

    def __post_init__(self):
        object.__setattr__(self, "severity", Verdict(self.severity))

    def to_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "threshold": self.threshold, "passed": self.passed,
                "severity": self.severity, "message": self.message}


@dataclass(frozen=True)
class ModelChecks:
    """The checks of one analysis and their verdict.

    Parameters
    ----------
    checks : tuple of Check
    """

    checks: tuple[Check, ...]

    @property
    def failed(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    @property
    def verdict(self) -> Verdict:
        """``ok``, ``caution`` or ``unreliable``: the worst severity among the failed checks."""
        return Verdict.worst(c.severity for c in self.failed)

    @property
    def reasons(self) -> tuple[str, ...]:
        """The messages of the failed checks, the most severe first."""
        return tuple(c.message for c in sorted(self.failed, key=lambda c: -c.severity.code))

    def __getitem__(self, name: str) -> Check:
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict:
        return {"verdict": self.verdict, "checks": [c.to_dict() for c in self.checks]}


def check_at_least(name: str, value: float | None, threshold: float, *, severity: Verdict, good: str, bad: str) -> Check:
    """A check that passes when ``value`` ≥ ``threshold`` (or is None)."""
    passed = value is None or value >= threshold
    return Check(name, value, threshold, passed, good if passed else bad, severity)


def check_at_most(name: str, value: float | None, threshold: float, *, severity: Verdict, good: str, bad: str) -> Check:
    """A check that passes when ``value`` ≤ ``threshold`` (or is None)."""
    passed = value is None or value <= threshold
    return Check(name, value, threshold, passed, good if passed else bad, severity)


def finite_or_none(value) -> float | None:
    return None if value is None or not np.isfinite(value) else float(value)
