"""Results of a stiffness analysis, as first-class objects.

A :class:`StiffnessResult` holds the stiffness course of one trial with its band and
observability, the inertia and damping used, and the protocol that produced them. It turns
itself into the contract's outputs: :meth:`StiffnessResult.to_frame` (the rows of
``stiffness.csv``) and :meth:`StiffnessResult.to_dict` (``summary.json``; :meth:`~StiffnessResult.summary`
is its older name). Like the curve, diagnosis and batch results it answers ``to_dict()``,
``to_frame()``, ``plot(ax=…)`` and ``report()``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .bandwidth import CornerScan
from .checks import ModelChecks, Verdict
from .coupling import CouplingFit
from .estimate.estimators import EstimatorFit
from .statespace.noise import NoiseLevels
from .estimate.observer import informed_samples
from .filtered import Filtered
from .files.outputs import jsonable
from .interval import Interval
from .mechanics.identification import Identification
from .mechanics.posterior import Posterior
from .protocol import Protocol
from .settings import DerivedSettings
from .provenance import settings_hash, software
from .trial import Trial
from .trial_level import REFERENCE_SKIP_S, TrialLevel

if TYPE_CHECKING:
    from .curve_result import CurveAnalysis
    from .scheduled.curve import ScheduleCurve

__all__ = ["StiffnessResult", "DerivedSettings", "Interval", "software"]

#: Samples per block of the per-sample masks taken in blocks (a long trial's temporaries stay small).
BLOCK = 1 << 18


@dataclass(frozen=True)
class StiffnessResult:
    """Stiffness of one trial.

    Parameters
    ----------
    trial : Trial
        The trial analysed.
    variant : {"external", "direct"}
    estimator : str
    stiffness : ndarray, shape (n,), N·m/rad (N/m)
    stiffness_lo, stiffness_hi : ndarray, shape (n,), N·m/rad (N/m)
        Bounds of the central band at ``ci_level``.
    observable : ndarray of bool, shape (n,)
        True where the estimate is informed by recent motion.
    inertia, damping : Interval or None
        Used by the external variant (None for the direct variant).
    ci_level : float
    seed : int
    protocol : Protocol
        The resolved protocol (file settings with command-line overrides).
    filtered : Filtered
        The trial's filtered signals and the corner, noise levels and motion frequency chosen.
    derived : DerivedSettings
        Observer gain, velocity threshold, observability window derived from the data.
    fit : EstimatorFit
        What the estimator fitted (the Kalman model's noise levels…).
    identification : Identification or None
        How m and b were obtained (None for the direct variant).
    checks : ModelChecks or None
        Whether the model fits the recording, and the verdict.
    coupling : CouplingFit or None
        A compliant coupling between limb and device found in the recorded dynamic stiffness
        (when ``coupling.found`` the stiffness is the limb's, the series springs undone).
    corner_scan : CornerScan or None
        The model's held-out torque prediction at each low-pass corner tried (None when the
        protocol sets the corner or the chain is the paper's).
    warnings : tuple of str
    reference : ndarray, shape (n,), or None
        Reference stiffness (``stiffness_true`` or a calibration), for validation.
    trial_level : TrialLevel or None
        The trial's median stiffness, stiffness at its mean torque and slope against torque, each
        with its interval from the course's joint uncertainty.
    curve : CurveAnalysis or None
        The stiffness against the cycle's phase or a recorded schedule (``[cycles]``,
        ``[columns.schedule]``): the course pooled by bins with its band, the resolution chosen
        and the curve's checks; None for a plain analysis.
    """

    trial: Trial
    variant: str
    estimator: str
    stiffness: np.ndarray
    stiffness_lo: np.ndarray
    stiffness_hi: np.ndarray
    observable: np.ndarray
    inertia: Interval | None
    damping: Interval | None
    ci_level: float
    seed: int
    protocol: Protocol
    filtered: Filtered
    derived: DerivedSettings
    fit: EstimatorFit
    identification: Identification | None = None
    checks: ModelChecks | None = None
    corner_scan: CornerScan | None = None
    coupling: CouplingFit | None = None
    warnings: tuple[str, ...] = ()
    reference: np.ndarray | None = None
    trial_level: TrialLevel | None = None
    curve: CurveAnalysis | None = None

    @property
    def posterior(self) -> Posterior | None:
        """Draws of (m, b, noise levels) when m and b were identified; None when both were given
        or for the direct variant."""
        return None if self.identification is None else self.identification.posterior

    @property
    def verdict(self) -> Verdict | None:
        """``ok``, ``caution`` or ``unreliable`` (:class:`~limbstiff.checks.ModelChecks`)."""
        return None if self.checks is None else self.checks.verdict

    @property
    def settings_sha256(self) -> str:
        """SHA-256 (hex) of the resolved settings, as ``summary.json`` records them."""
        return settings_hash(jsonable(self.protocol.to_dict()), length=64)

    @property
    def observable_fraction(self) -> float:
        """Share of samples where the estimate is informed by motion."""
        return float(np.mean(self.observable))

    @property
    def by_phase(self) -> ScheduleCurve | None:
        """The stiffness against the cycle's phase (``stiffness_by_phase.csv``), or None."""
        return self.curve.curve if self.curve is not None and self.curve.against == "phase" else None

    @property
    def by_schedule(self) -> ScheduleCurve | None:
        """The stiffness against the recorded schedule (``stiffness_by_schedule.csv``), or None."""
        return self.curve.curve if self.curve is not None and self.curve.against == "schedule" else None

    def plot(self, ax=None, *, against: str = "time", reference: bool = True):
        """Draw the stiffness into a matplotlib axes (the report's figures, one at a time).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; pyplot's current axes when omitted.
        against : {"time", "angle", "torque", "phase", "schedule"}
            ``time``: the course with its band, uninformed stretches shaded (page 1's figure);
            ``angle``/``torque``: medians in bins with the band, over the informed samples;
            ``phase``/``schedule``: the curve of an ensemble or a schedule analysis, its band and
            the cycles' spread (:meth:`limbstiff.curve_result.CurveAnalysis.plot`).
        reference : bool
            With ``against="time"``, draw the reference stiffness when there is one.

        Returns
        -------
        matplotlib.axes.Axes
        """
        from .report.plots import plot_relation, plot_stiffness
        if against == "time":
            return plot_stiffness(self, ax=ax, reference=reference)
        if against in ("phase", "schedule"):
            if self.curve is None or self.curve.against != against:
                raise ValueError(f"this analysis has no stiffness by {against} (give [cycles] or a schedule column)")
            return self.curve.plot(ax=ax, unit_stiffness=self.trial.units["stiffness"])
        return plot_relation(self, against, ax=ax)

    def report(self) -> str:
        """What page 1 of the PDF report says, as text: verdict with reasons, the trial's figures
        with their intervals, warnings, the recording."""
        from .digest import text_report
        return text_report(self)

    def __repr__(self) -> str:
        median, _, _ = self.informed_stiffness()
        unit = self.trial.units["stiffness"]
        span = "" if median.is_fixed else f" [{median.lo:.4g}, {median.hi:.4g}]"
        return (f"<StiffnessResult {self.trial.name!r}: median stiffness {median.median:.4g}{span} {unit}, "
                f"verdict {self.verdict or '—'}, {100 * self.observable_fraction:.0f} % informed>")

    def columns(self) -> dict[str, np.ndarray]:
        """The per-sample columns of ``stiffness.csv``, in order, as arrays (see :meth:`to_frame`).

        Returns
        -------
        dict of str to ndarray, each of shape (n,)
            ``time_s``, ``stiffness``, ``stiffness_lo``, ``stiffness_hi`` (float, the result's own
            arrays, not copies) and ``observable`` (int).
        """
        return {
            "time_s": self.trial.time,
            "stiffness": self.stiffness,
            "stiffness_lo": self.stiffness_lo,
            "stiffness_hi": self.stiffness_hi,
            "observable": self.observable.astype(int),
        }

    def to_frame(self):
        """The per-sample table of ``stiffness.csv`` as a :class:`pandas.DataFrame`.

        One row per sample; columns, in order: ``time_s`` (s); ``stiffness`` (the estimate, N·m/rad,
        or N/m for a translational trial); ``stiffness_lo``, ``stiffness_hi`` (the same unit: the
        band's bounds at :attr:`ci_level`; ``stiffness_hi`` is inf where the band is unbounded);
        ``observable`` (int: 1 where the sample is informed by motion, 0 elsewhere).
        """
        import pandas as pd

        return pd.DataFrame(self.columns())

    def reference_samples(self, *, skip: float = REFERENCE_SKIP_S) -> np.ndarray:
        """The samples the error against the reference is taken over: informed by motion, after the
        first ``skip`` s, with a non-zero reference (bool, shape (n,)). Needs a reference.

        Taken in blocks of :data:`BLOCK` samples: no temporary as long as the trial."""
        t, reference, observable = self.trial.time, self.reference, self.observable
        use = np.empty(t.size, dtype=bool)
        for at in range(0, t.size, BLOCK):
            part = slice(at, at + BLOCK)
            use[part] = observable[part] & (t[part] - t[0] >= skip) & (reference[part] != 0)
        return use

    def reference_error(self, *, skip: float = REFERENCE_SKIP_S) -> dict | None:
        """Relative error against the reference stiffness, over :meth:`reference_samples`.

        Returns
        -------
        dict or None
            ``median`` and ``p90`` of |σ̂ − σ|/|σ|, ``coverage`` of the band, and ``n`` samples
            used; None without a reference.
        """
        if self.reference is None:
            return None
        use = self.reference_samples(skip=skip)
        if not np.any(use):
            return {"median": None, "p90": None, "coverage": None, "n": 0}
        # in place where it can be: on a long trial each temporary is as long as the trial
        reference = self.reference[use]
        inside = self.stiffness_lo[use] <= reference
        inside &= reference <= self.stiffness_hi[use]
        coverage = float(np.mean(inside))
        del inside
        rel = self.stiffness[use]
        rel -= reference
        np.abs(rel, out=rel)
        rel /= np.abs(reference, out=reference)
        del reference
        # both partition rel in place: the same order statistics as on a copy, without the copy
        median = float(np.median(rel, overwrite_input=True))
        return {"median": median, "p90": float(np.percentile(rel, 90, overwrite_input=True)),
                "coverage": coverage, "n": int(use.sum())}

    def details(self) -> dict:
        """The ``details`` of ``summary.json``: what was derived from the data (JSON-ready)."""
        f, d = self.filtered, self.derived
        return {
            "observer_gain": d.observer_gain,
            "observer_memory": d.observer_memory,
            "discretisation": d.discretisation,
            "derivatives": f.chain.kind,
            "bandwidth": dict(f.bandwidth.to_dict(), scan=None if self.corner_scan is None
                              else self.corner_scan.to_dict()),
            "torque_quantisation_step": f.torque_quantisation_step,
            "motion_frequency_hz": f.motion_hz,
            "range_of_motion": d.range_of_motion,
            "velocity_threshold": d.velocity_threshold,
            "observable_window_s": d.observable_window_s,
            "identification": None if self.identification is None else self.identification.to_dict(),
            "coupling": None if self.coupling is None else self.coupling.to_dict(),
            "estimator": self.fit.to_dict(),
        }

    def informed_stiffness(self) -> tuple[Interval, float, float]:
        """The trial's typical stiffness over its informed samples (all when none is).

        Returns
        -------
        median : Interval
            The median of the estimate with its interval from the course's joint uncertainty
            (:attr:`trial_level`), N·m/rad (N/m); without it, the medians of the band's bounds.
        low, high : float
            Smallest and largest estimate, N·m/rad (N/m).
        """
        obs = informed_samples(self.observable)
        # no copy of the informed samples for their extremes; each median partitions its own copy
        # in place (the same value as on a copy of it)
        low = float(np.min(self.stiffness, where=obs, initial=np.inf))
        high = float(np.max(self.stiffness, where=obs, initial=-np.inf))
        if self.trial_level is not None and np.isfinite(self.trial_level.median_stiffness.lo):
            return self.trial_level.median_stiffness, low, high
        return Interval(*(float(np.median(x[obs], overwrite_input=True))
                          for x in (self.stiffness, self.stiffness_lo, self.stiffness_hi))), low, high

    def summary(self) -> dict:
        """The content of ``summary.json``: :meth:`to_dict` under its older name (kept for the
        scripts that call it)."""
        return self.to_dict()

    def to_dict(self) -> dict:
        """The content of ``summary.json`` (docs/interface.md section 4), JSON-ready."""
        median, low, high = self.informed_stiffness()
        stiffness = dict(median.to_dict(), min=low, max=high)
        trial = self.trial
        curve = {} if self.curve is None else {f"by_{self.curve.against}": jsonable(self.curve.to_dict())}
        return {
            "trial": trial.name,
            "source": trial.source,
            "source_sha256": trial.source_sha256,
            "variant": self.variant,
            "estimator": self.estimator,
            "kind": trial.kind,
            "fs_hz": trial.fs,
            "n_samples": trial.n_samples,
            "duration_s": trial.duration,
            "ci_level": self.ci_level,
            "inertia": None if self.inertia is None else self.inertia.to_dict(),
            "damping": None if self.damping is None else self.damping.to_dict(),
            "stiffness": stiffness,
            "trial_level": None if self.trial_level is None else jsonable(self.trial_level.to_dict()),
            "observable_fraction": self.observable_fraction,
            "verdict": self.verdict,
            "verdict_reasons": [] if self.checks is None else list(self.checks.reasons),
            "checks": [] if self.checks is None else jsonable([c.to_dict() for c in self.checks.checks]),
            "mcmc": jsonable(None if self.posterior is None else self.posterior.diagnostics.to_dict()),
            "reference_error": self.reference_error(),
            "warnings": list(self.warnings),
            "units": result_units(trial.units),
            "seed": self.seed,
            "software": software(),
            "metadata": dict(trial.metadata),
            "details": jsonable(self.details()),
            "settings": jsonable(self.protocol.to_dict()),
            "settings_sha256": self.settings_sha256,
            **curve,
        }


def result_units(units) -> dict[str, str]:
    """The ``units`` block of the JSON outputs: the trial's SI units and the Kalman model's noise
    levels' (``noise_levels`` in ``identification`` and ``details``)."""
    return {**units, **{f"noise_levels.{k}": v for k, v in NoiseLevels.units(units["torque"],
                                                                              units["stiffness"]).items()}}
