"""The outcome of a diagnosis as first-class objects: :class:`Candidate` and :class:`Diagnosis`.

``Diagnosis.to_dict()`` is the content of ``diagnosis.json`` (INTERFACE.md section 5: keys
``gap`` {metric, train, heldout}, ``where``, ``candidates`` [{effect, params, gap_train,
gap_heldout, shrink_heldout, evidence, …}] and ``diagnosis``); ``Diagnosis.plot(path)`` hands
the PDF over to :mod:`limbstiff.report.diagnosis`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .. import __version__


def jsonable(value):
    """Plain JSON values: numpy scalars and arrays converted, non-finite floats as None."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


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


@dataclass(frozen=True)
class Candidate:
    """One unmodelled effect, fitted and judged against the nominal model.

    Parameters
    ----------
    effect : str
    description : str
    params : Mapping[str, Any]
        Fitted parameters on all the data (shape and amplitudes, SI units).
    units : Mapping[str, str]
        The unit of each parameter.
    gap_train : float
        Gap with the effect fitted and scored on all the data (variance not accounted for).
    gap_heldout : float
        Gap on held-out data, the effect fitted without them.
    shrink_heldout : float
        1 − gap_heldout / (nominal held-out gap under the same scheme).
    shrink_interval : tuple of float
        Bootstrap interval of ``shrink_heldout`` over the scoring units.
    evidence : Mapping[str, Any]
        Test, correction, scheme, step-wise gains.
    stiffness_bias : Mapping[str, Any]
        Median stiffness of each trial, nominal and with the effect removed, and their relative
        difference (nominal/corrected − 1): how much the effect biases the estimate.
    """

    effect: str
    description: str
    params: Mapping[str, Any]
    units: Mapping[str, str]
    gap_train: float
    gap_heldout: float
    shrink_heldout: float
    shrink_interval: tuple
    evidence: Mapping[str, Any] = field(default_factory=dict)
    stiffness_bias: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return jsonable({"effect": self.effect, "description": self.description, "params": dict(self.params),
                         "units": dict(self.units),
                         "gap_train": self.gap_train, "gap_heldout": self.gap_heldout,
                         "shrink_heldout": self.shrink_heldout,
                         "shrink_heldout_interval": list(self.shrink_interval),
                         "evidence": dict(self.evidence), "stiffness_bias": dict(self.stiffness_bias)})


@dataclass(frozen=True)
class Diagnosis:
    """Where the nominal model misses, which effects cause it, and how far the gap shrinks.

    Parameters
    ----------
    trials : tuple of Mapping
        Per trial: name, source, sha256, sampling, m and b used, filter, median stiffness.
    metric : str
        Definition of the gap.
    gap_train, gap_heldout : float
        Gap of the nominal model (in-sample, and scored fold by fold).
    noise_floor : float
        Gap white sensor noise alone would leave (lower bound, see ``nominal.noise_floor``).
    heldout : Mapping
        The held-out scheme (folds, guard, units).
    where : Mapping
        Per trial: ``time``, ``frequency``, ``regime``, ``whiteness``, ``cross_correlation``.
    candidates : tuple of Candidate
        Every effect tried, ranked by held-out shrinkage.
    diagnosis : tuple of str
        The effects judged responsible, in the order they were added (most important first).
    steps : tuple of Mapping
        The greedy selection, step by step.
    ambiguities : tuple of Mapping
        Pairs the data cannot tell apart, and the experiment that would.
    after : Mapping
        The model with every chosen effect: gaps, shrinkage with interval, stiffness change.
    settings : Mapping
    notes : tuple of str
    warnings : tuple of str
    seed : int
    series : Mapping
        Arrays for the report (not written to JSON): per trial, rows' time, residual before and
        after, windowed gaps.
    """

    trials: tuple
    metric: str
    gap_train: float
    gap_heldout: float
    noise_floor: float
    heldout: Mapping
    where: Mapping
    candidates: tuple
    diagnosis: tuple
    steps: tuple
    ambiguities: tuple
    after: Mapping
    settings: Mapping
    notes: tuple = ()
    warnings: tuple = ()
    seed: int = 0
    series: Mapping = field(default_factory=dict, repr=False, compare=False)

    def candidate(self, name: str) -> Candidate:
        return next(c for c in self.candidates if c.effect == name)

    def to_dict(self) -> dict:
        """The content of ``diagnosis.json``."""
        return jsonable({
            "gap": {"metric": self.metric, "train": self.gap_train, "heldout": self.gap_heldout,
                    "noise_floor": self.noise_floor},
            "diagnosis": list(self.diagnosis),
            "candidates": [c.to_dict() for c in self.candidates],
            "after": dict(self.after),
            "ambiguities": list(self.ambiguities),
            "where": dict(self.where),
            "steps": list(self.steps),
            "heldout": dict(self.heldout),
            "trials": list(self.trials),
            "notes": list(self.notes),
            "warnings": list(self.warnings),
            "settings": dict(self.settings),
            "units": UNITS,
            "seed": self.seed,
            "software": {"name": "limbstiff", "version": __version__},
        })

    def plot(self, path) -> None:
        """Write ``diagnosis.pdf`` (see :func:`limbstiff.report.diagnosis.write_diagnosis_report`)."""
        from ..report.diagnosis import write_diagnosis_report
        write_diagnosis_report(self, path)
