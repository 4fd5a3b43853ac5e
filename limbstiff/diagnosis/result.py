"""The outcome of a diagnosis as first-class objects: :class:`Diagnosis` and its :class:`Candidate`
effects (the typed parts they hold: :mod:`limbstiff.diagnosis.parts`; a trial's own selection:
:mod:`limbstiff.diagnosis.per_trial`).

``Diagnosis.to_dict()`` is the content of ``diagnosis.json`` (docs/interface.md section 5: keys
``gap`` {metric, train, heldout}, ``where``, ``candidates`` [{effect, params, gap_train,
gap_heldout, shrink_heldout, evidence, …}] and ``diagnosis``): the one place the parts become
dicts, a part's fields named as its JSON keys (:func:`jsonable`). Like every result of the package
it answers ``to_dict()``, ``to_frame()`` (the candidates' table), ``plot(ax=…)`` (the candidates'
held-out shrinkage, :func:`limbstiff.report.axes_diagnosis.plot_candidates`) and ``report()`` (in
words); ``Diagnosis.write_pdf(path)`` hands ``diagnosis.pdf`` over to :mod:`limbstiff.report.diagnosis`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike
from typing import TYPE_CHECKING, Mapping

from ..files.outputs import jsonable
from ..provenance import software
from .parts import (After, Evidence, HeldOut, Mechanics, NotTried, Settings, Step, StiffnessBias, TrialInfo,
                    TrialStiffness)
from .per_trial import TrialSelection

if TYPE_CHECKING:
    from .residual import TrialSeries, Where
    from .selection import Ambiguity

#: Units of the quantities of ``diagnosis.json`` whose key does not name one (rotational joints;
#: read N for N·m and m for rad on a translational one). Effect parameters carry their own
#: (``candidates[].units``, ``after.units``).
UNITS = {
    "gap": "fraction of the torque's variance (sum of squared one-step prediction errors over the sum of squared "
           "deviations of the torque from its mean)",
    "trials.inertia": "kg·m²", "trials.damping": "N·m·s/rad", "trials.stiffness_median": "N·m/rad",
    "trials.noise_levels.measurement": "(N·m)²", "trials.noise_levels.torque_walk": "(N·m)²/s",
    "trials.noise_levels.stiffness_walk": "(N·m/rad)²/s", "trials.noise_levels.coupled_walk": "(N·m/rad)²/s",
    "after.mechanics.inertia": "kg·m²",
    "after.mechanics.damping": "N·m·s/rad", "stiffness_bias.relative": "fraction (nominal/corrected − 1)",
    "stiffness_bias.nominal": "N·m/rad", "stiffness_bias.corrected": "N·m/rad",
    "where.frequency.residual_psd": "(N·m)²/Hz", "where.frequency.torque_psd": "(N·m)²/Hz",
}
#: The stiffness's unit in :meth:`Diagnosis.report` (N/m on a translational joint, as :data:`UNITS`).
UNIT = UNITS["trials.stiffness_median"]


@dataclass(frozen=True)
class Candidate:
    """One unmodelled effect, fitted and judged against the nominal model.

    Parameters
    ----------
    effect : str
    description : str
    params : Mapping of str to float or None
        Fitted parameters on all the data (shape and amplitudes, SI units).
    units : Mapping of str to str
        The unit of each parameter.
    gap_train : float
        Gap with the effect fitted and scored on all the data (variance not accounted for).
    gap_heldout : float
        Gap on held-out data, the effect fitted without them.
    shrink_heldout : float
        1 − gap_heldout / (nominal held-out gap under the same scheme).
    shrink_interval : tuple of float
        Bootstrap interval of ``shrink_heldout`` over the scoring units.
    evidence : Evidence or NotTried
        Test, scheme, step; or why it was not tried.
    stiffness_bias : StiffnessBias or None
        Median stiffness of each trial, nominal and with the effect removed, and their relative
        difference (nominal/corrected − 1): how much the effect biases the estimate (None: not
        tried).
    mechanics : Mapping of str to Mechanics or None
        By trial, m and b fitted together with the effect (None: m and b were given).
    """

    effect: str
    description: str
    params: Mapping[str, float | None]
    units: Mapping[str, str]
    gap_train: float
    gap_heldout: float
    shrink_heldout: float
    shrink_interval: tuple[float, float]
    evidence: Evidence | NotTried
    stiffness_bias: StiffnessBias | None = None
    mechanics: Mapping[str, Mechanics] | None = None

    def to_dict(self) -> dict:
        """The candidate's entry of ``diagnosis.json`` (m and b fitted with it among its params)."""
        params = dict(self.params)
        if self.mechanics is not None:
            params["mechanics_fitted_with_it"] = self.mechanics
        return jsonable({"effect": self.effect, "description": self.description, "params": params,
                         "units": dict(self.units),
                         "gap_train": self.gap_train, "gap_heldout": self.gap_heldout,
                         "shrink_heldout": self.shrink_heldout,
                         "shrink_heldout_interval": list(self.shrink_interval),
                         "evidence": self.evidence, "stiffness_bias": self.stiffness_bias or {}})


@dataclass(frozen=True)
class Diagnosis:
    """Where the nominal model misses, which effects cause it, and how far the gap shrinks.

    Parameters
    ----------
    trials : tuple of TrialInfo
    metric : str
        Definition of the gap.
    gap_train, gap_heldout : float
        Gap of the nominal model (in-sample, and scored fold by fold).
    noise_floor : float
        Gap white sensor noise alone would leave (lower bound, see ``nominal.noise_floor``).
    heldout : HeldOut
        The held-out scheme.
    where : Mapping of str to Where
        By trial name: where the nominal model's innovations lie.
    candidates : tuple of Candidate
        Every effect tried, ranked by held-out shrinkage, then those not tried.
    diagnosis : tuple of str
        The effects judged responsible, in the order they were added (most important first).
    steps : tuple of Step
        The greedy selection, step by step.
    ambiguities : tuple of Ambiguity
        Pairs the data cannot tell apart, and the experiment that would.
    after : After
        The model with every chosen effect: gaps, shrinkage with interval, stiffness change.
    settings : Settings
    notes : tuple of str
    warnings : tuple of str
    seed : int
    series : Mapping of str to TrialSeries
        By trial name, the innovations for the report (not written to JSON).
    per_trial : tuple of TrialSelection
        With several trials, each trial's own selection (made on it alone) beside the pooled
        one; empty for one trial, whose own selection is ``diagnosis``.
    disagreements : tuple of str
        A warning when a trial's own selection differs from the pooled one: the trials, their
        effects, and what to do; empty when they agree.
    stiffness : tuple of TrialStiffness
        Per trial, the stiffness ``summary.csv`` reports and the stiffness with the chosen effects
        in the model (``limbstiff analyze --effect``), each with its interval.
    """

    trials: tuple[TrialInfo, ...]
    metric: str
    gap_train: float
    gap_heldout: float
    noise_floor: float
    heldout: HeldOut
    where: Mapping[str, Where]
    candidates: tuple[Candidate, ...]
    diagnosis: tuple[str, ...]
    steps: tuple[Step, ...]
    ambiguities: tuple[Ambiguity, ...]
    after: After
    settings: Settings
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    seed: int = 0
    series: Mapping[str, TrialSeries] = field(default_factory=dict, repr=False, compare=False)
    per_trial: tuple[TrialSelection, ...] = ()
    disagreements: tuple[str, ...] = ()
    stiffness: tuple[TrialStiffness, ...] = ()

    def candidate(self, name: str) -> Candidate:
        return next(c for c in self.candidates if c.effect == name)

    def to_dict(self) -> dict:
        """The content of ``diagnosis.json``."""
        return jsonable({
            "gap": {"metric": self.metric, "train": self.gap_train, "heldout": self.gap_heldout,
                    "noise_floor": self.noise_floor},
            "diagnosis": list(self.diagnosis),
            "per_trial": list(self.per_trial),
            "disagreements": list(self.disagreements),
            "stiffness": list(self.stiffness),
            "candidates": list(self.candidates),
            "after": self.after,
            "ambiguities": list(self.ambiguities),
            "where": dict(self.where),
            "steps": list(self.steps),
            "heldout": self.heldout,
            "trials": list(self.trials),
            "notes": list(self.notes),
            "warnings": list(self.warnings),
            "settings": self.settings,
            "units": UNITS,
            "seed": self.seed,
            "software": software(),
        })

    def to_frame(self):
        """The candidates as a :class:`pandas.DataFrame`, one row each in :attr:`candidates`' order:
        ``effect``, ``tried``, ``chosen``, ``gap_train``, ``gap_heldout`` (fractions of the torque's
        variance), ``shrink_heldout`` with ``shrink_lo``, ``shrink_hi`` (its interval),
        ``p_adjusted`` (NaN when not tried) and ``stiffness_bias`` (the median relative change,
        nominal/corrected − 1; NaN when not measured)."""
        import pandas as pd

        def row(c: Candidate) -> dict:
            bias = None if c.stiffness_bias is None else c.stiffness_bias.median_relative
            return {"effect": c.effect, "tried": c.evidence.tried, "chosen": c.effect in self.diagnosis,
                    "gap_train": c.gap_train, "gap_heldout": c.gap_heldout, "shrink_heldout": c.shrink_heldout,
                    "shrink_lo": c.shrink_interval[0], "shrink_hi": c.shrink_interval[1],
                    "p_adjusted": c.evidence.p_adjusted if c.evidence.tried else float("nan"),
                    "stiffness_bias": float("nan") if bias is None else bias}
        return pd.DataFrame([row(c) for c in self.candidates])

    def plot(self, ax=None):
        """Draw the candidates' held-out shrinkage with their intervals into a matplotlib axes
        (:func:`limbstiff.report.axes_diagnosis.plot_candidates`); returns the axes. (The PDF, which
        ``plot(path)`` wrote before, is :meth:`write_pdf`.)"""
        if isinstance(ax, (str, PathLike)):
            raise TypeError(f"Diagnosis.plot draws into a matplotlib axes; write {ax} with write_pdf(path)")
        from ..report.axes_diagnosis import plot_candidates
        return plot_candidates(self, ax=ax)

    @property
    def headline(self) -> str:
        """The held-out gap and the effects found, in one line (what ``limbstiff diagnose`` prints)."""
        found = ", ".join(self.diagnosis) if self.diagnosis else "none (the nominal model explains the data)"
        return f"gap {100 * self.gap_heldout:.2f} % held out; effects: {found}"

    def report(self) -> str:
        """The diagnosis in words: the gap and the effects found, how far they shrink it, each
        trial's stiffness with them in the model, then disagreements, ambiguities and warnings."""
        from ..digest import interval_text
        lines = [self.headline + f" (noise floor {100 * self.noise_floor:.2f} %)."]
        if self.diagnosis and self.after.shrink_heldout is not None:
            lo, hi = self.after.shrink_heldout_interval
            lines.append(f"With them the held-out gap is {100 * self.after.gap_heldout:.2f} %: "
                         f"{100 * self.after.shrink_heldout:.0f} % of it removed [{100 * lo:.0f}, {100 * hi:.0f}].")
        for s in self.stiffness:
            with_effects = ("" if s.with_effects is None
                            else f"; with {', '.join(s.effects)} in the model {interval_text(s.with_effects, UNIT)}")
            lines.append(f"{s.trial}: stiffness {interval_text(s.reported, UNIT)}{with_effects}"
                         + (f" ({s.note})" if s.note else ""))
        lines += [f"{a.effects[0]} and {a.effects[1]} cannot be told apart: {a.reason}; separate them by "
                  f"{a.separate_by}" for a in self.ambiguities]
        lines += [f"warning: {w}" for w in (*self.disagreements, *self.warnings)]
        return "\n".join(lines)

    def write_pdf(self, path) -> None:
        """Write ``diagnosis.pdf`` (see :func:`limbstiff.report.diagnosis.write_diagnosis_report`)."""
        from ..report.diagnosis import write_diagnosis_report
        write_diagnosis_report(self, path)
