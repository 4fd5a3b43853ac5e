"""The typed parts of a diagnosis (:class:`~limbstiff.diagnosis.result.Diagnosis`): one frozen
dataclass each, its fields named as the keys of ``diagnosis.json`` (docs/interface.md section 5),
units in the docstrings. They become dicts only where the JSON is written
(:func:`limbstiff.files.outputs.jsonable`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping

from ..files.outputs import OMIT_NONE

if TYPE_CHECKING:
    from ..statespace.noise import NoiseLevels


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
class TrialStiffness:
    """One trial's stiffness as ``summary.csv`` reports it, and with the chosen effects in the model.

    Parameters
    ----------
    trial : str
    reported : Interval
        The median stiffness ``limbstiff analyze`` reports (``summary.csv``), with its interval, N·m/rad.
    verdict : str
        That analysis's verdict.
    effects : tuple of str
        The chosen effects put in the model (``limbstiff analyze --effect …``); empty when none
        of them can be.
    with_effects : Interval or None
        The median stiffness of that analysis, with its interval (the effects' amplitudes' uncertainty
        carried), N·m/rad; None when no effect could be put in the model or the analysis failed.
    verdict_with_effects : str or None
    inertia_with_effects, damping_with_effects : Interval or None
        m (kg·m²) and b (N·m·s/rad) of that analysis.
    note : str or None
        Why there is no corrected stiffness, or which chosen effects could not be put in the model.
    """

    trial: str
    reported: object
    verdict: str
    effects: tuple[str, ...]
    with_effects: object | None
    verdict_with_effects: str | None
    inertia_with_effects: object | None = None
    damping_with_effects: object | None = None
    note: str | None = None
