"""The outcome of a diagnosis as first-class objects: :class:`Diagnosis`, its :class:`Candidate`
effects and the typed parts they hold.

``Diagnosis.to_dict()`` is the content of ``diagnosis.json`` (docs/interface.md section 5: keys
``gap`` {metric, train, heldout}, ``where``, ``candidates`` [{effect, params, gap_train,
gap_heldout, shrink_heldout, evidence, …}] and ``diagnosis``): the one place the parts become
dicts, a part's fields named as its JSON keys (:func:`jsonable`). ``Diagnosis.plot(path)`` hands
the PDF over to :mod:`limbstiff.report.diagnosis`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping

from .. import __version__
from ..files.outputs import OMIT_NONE, jsonable

if TYPE_CHECKING:
    from ..statespace.noise import NoiseLevels
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


@dataclass(frozen=True)
class TrialInfo:
    """One trial as the diagnosis saw it: source, sampling, nominal model, steps and gap.

    Parameters
    ----------
    trial : str
        Its name.
    source, source_sha256 : str or None
        The file it was read from and its SHA-256 (None for a trial made in memory).
    fs_hz : float, Hz
    duration_s : float, s
    variant : str
        The analysis's variant (``"external"`` or ``"direct"``).
    inertia : float, kg·m²
    damping : float, N·m·s/rad
        The nominal m and b (0 for the direct variant).
    mechanics : str
        ``"given"``, ``"identified"`` or ``"none"``.
    cutoff_hz : float or None, Hz
        The corner of the analysis's low-pass.
    motion_hz : float, Hz
    steps : int
        Scored model steps.
    step_s : float, s
        Time between model steps.
    units : int
        Scoring units (at most one motion period each).
    stiffness_median : float, N·m/rad
        Median stiffness of the analysis.
    noise_levels : NoiseLevels
        The nominal model's noise levels (units: :data:`UNITS`).
    noise_floor : float
        Gap white sensor noise alone would leave.
    gap_train : float
        The nominal model's in-sample gap on this trial.
    """

    trial: str
    source: str | None
    source_sha256: str | None
    fs_hz: float
    duration_s: float
    variant: str
    inertia: float
    damping: float
    mechanics: str
    cutoff_hz: float | None
    motion_hz: float
    steps: int
    step_s: float
    units: int
    stiffness_median: float
    noise_levels: NoiseLevels
    noise_floor: float
    gap_train: float


@dataclass(frozen=True)
class HeldOut:
    """The held-out scheme.

    Parameters
    ----------
    scheme : str
        In words.
    folds : int
    guard_s : float, s
        Data left out on each side of a held-out block.
    units : int
        Scoring units over all trials.
    unit_s, step_s : tuple of float, s
        Per trial: length of a scoring unit, time between model steps.
    """

    scheme: str
    folds: int
    guard_s: float
    units: int
    unit_s: tuple[float, ...]
    step_s: tuple[float, ...]


@dataclass(frozen=True)
class Settings:
    """The settings of the selection, the nominal model and the test.

    Parameters
    ----------
    alpha : float
        Family-wise error rate of a selection step.
    relevance : float
        Smallest share of the nominal held-out gap an effect must remove.
    permutations, bootstrap : int
        Sign flips of the test; resamples of the intervals.
    collinear : float
        |r| of two fitted torques above which they cannot be told apart.
    ci_level : float
        Level of the intervals.
    model : str
    settling_periods : float
        Motion periods left out at each trial's start while the filter settles.
    test : str
    relevance_reason : str
    """

    alpha: float
    relevance: float
    permutations: int
    bootstrap: int
    collinear: float
    ci_level: float
    model: str
    settling_periods: float
    test: str
    relevance_reason: str


@dataclass(frozen=True)
class StepScore:
    """One candidate at one selection step, against the model chosen so far.

    Parameters
    ----------
    shrink_heldout : float
        Share of the current model's held-out gap it removes.
    share_of_nominal_gap : float
        Share of the nominal model's held-out gap it removes.
    p_value, p_adjusted : float
        One-sided sign-flip p-value, and Holm-corrected over the step's candidates.
    significant, relevant : bool
    """

    shrink_heldout: float
    share_of_nominal_gap: float
    p_value: float
    p_adjusted: float
    significant: bool
    relevant: bool


@dataclass(frozen=True)
class Step:
    """One step of the greedy selection.

    Parameters
    ----------
    step : int
        From 1.
    added : str or None
        The effect added (None: the search stopped).
    candidates : Mapping of str to StepScore
        Every candidate of the step, by name.
    """

    step: int
    added: str | None
    candidates: Mapping[str, StepScore]


@dataclass(frozen=True)
class Mechanics:
    """m and b fitted together with effects.

    Parameters
    ----------
    inertia : float, kg·m²
    damping : float, N·m·s/rad
    """

    inertia: float
    damping: float


@dataclass(frozen=True)
class TrialBias:
    """One trial's median stiffness, nominal and with effects removed.

    Parameters
    ----------
    nominal : float, N·m/rad
    corrected : float or None, N·m/rad
        None when the corrected trial could not be estimated (``error`` says why).
    relative : float or None
        nominal/corrected − 1: the bias the effects put on the nominal estimate.
    error : str or None
    """

    nominal: float
    corrected: float | None
    relative: float | None
    error: str | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class StiffnessBias:
    """How much effects bias the stiffness estimate.

    Parameters
    ----------
    per_trial : Mapping of str to TrialBias
        By trial name.
    median_relative : float or None
        Median of the trials' relative biases (None: none could be estimated).
    """

    per_trial: Mapping[str, TrialBias]
    median_relative: float | None


@dataclass(frozen=True)
class StiffnessWalks:
    """The stiffness walk (Q_σ + Q_c) per trial of two models.

    Parameters
    ----------
    nominal, with_effect : tuple of float, (N·m/rad)²/s
    unit : str
    """

    nominal: tuple[float, ...]
    with_effect: tuple[float, ...]
    unit: str = "(N·m/rad)²/s"


@dataclass(frozen=True)
class Evidence:
    """How a tried candidate was judged.

    Parameters
    ----------
    identifiable_share : float
        Share of the effect's torque not explained by the nominal model's own terms.
    p_value, p_adjusted : float
        Against the nominal model (step 1).
    significant, relevant : bool
    share_of_nominal_gap : float
    units : int
        Scoring units.
    units_improved : float
        Share of the units whose held-out error it lowers.
    fold_params : tuple of Mapping or None
        The shape fitted on each fold's training data (None: the effect has no shape).
    stiffness_walk : StiffnessWalks
        The nominal model's and the model's with the effect.
    chosen : bool
    step : int or None
        The selection step that added it.
    shrink_after_chosen : float or None
        Not chosen: its shrink at the last step it was scored at.
    grid : str
        Why its grid spans what it spans.
    tried : bool
        True.
    """

    tried: bool = field(default=True, init=False)
    identifiable_share: float
    p_value: float
    p_adjusted: float
    significant: bool
    relevant: bool
    share_of_nominal_gap: float
    units: int
    units_improved: float
    fold_params: tuple[Mapping[str, float | None], ...] | None
    stiffness_walk: StiffnessWalks
    chosen: bool
    step: int | None
    shrink_after_chosen: float | None
    grid: str


@dataclass(frozen=True)
class NotTried:
    """Why an effect of the interface was not tried (``tried`` is False)."""

    tried: bool = field(default=False, init=False)
    reason: str


@dataclass(frozen=True)
class After:
    """The model with every chosen effect.

    Parameters
    ----------
    effects : tuple of str
        In the order chosen.
    gap_train, gap_heldout : float
    shrink_heldout : float or None
        1 − its held-out gap over the nominal model's (None when that is 0).
    shrink_heldout_interval : tuple of float
        Bootstrap interval over the scoring units.
    params : Mapping of str to Mapping
        By effect: its physical parameters (SI units).
    units : Mapping of str to Mapping
        By effect: the unit of each parameter.
    stiffness_walk : tuple of float, (N·m/rad)²/s
        Per trial.
    mechanics : Mapping of str to Mechanics or None
        By trial, m and b fitted with the effects (None: m and b were given).
    stiffness_bias : StiffnessBias or None
        None when no effect was chosen.
    """

    effects: tuple[str, ...]
    gap_train: float
    gap_heldout: float
    shrink_heldout: float | None
    shrink_heldout_interval: tuple[float, float]
    params: Mapping[str, Mapping[str, float | None]]
    units: Mapping[str, Mapping[str, str]]
    stiffness_walk: tuple[float, ...]
    mechanics: Mapping[str, Mechanics] | None = field(metadata=OMIT_NONE)
    stiffness_bias: StiffnessBias | None


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

    def candidate(self, name: str) -> Candidate:
        return next(c for c in self.candidates if c.effect == name)

    def to_dict(self) -> dict:
        """The content of ``diagnosis.json``."""
        return jsonable({
            "gap": {"metric": self.metric, "train": self.gap_train, "heldout": self.gap_heldout,
                    "noise_floor": self.noise_floor},
            "diagnosis": list(self.diagnosis),
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
            "software": {"name": "limbstiff", "version": __version__},
        })

    def plot(self, path) -> None:
        """Write ``diagnosis.pdf`` (see :func:`limbstiff.report.diagnosis.write_diagnosis_report`)."""
        from ..report.diagnosis import write_diagnosis_report
        write_diagnosis_report(self, path)
