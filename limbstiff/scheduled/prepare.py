"""What a curve analysis is run on: the cycles cut and their ensemble mean taken off, or the
schedule read; the variable the stiffness is a function of; the units held out.

Ensembles (``[cycles]``): the trial is cropped to its whole cycles and the ensemble mean — what
every cycle repeats, the movement and the torque it needs — is taken off the angle and the torque
(:func:`limbstiff.cycles.ensemble_mean`), leaving the perturbations' responses, on which the
stiffness at each phase is identified. Schedules (``[columns.schedule]``): the trial is kept whole;
the slow change of the operating point is the model's torque walk and moving average, and the
held-out units are stretches of :data:`SCHEDULE_UNIT_S` seconds. Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import cycles
from ..errors import TrialError
from ..protocol import ENSEMBLE_HOW, ENSEMBLE_MARKER
from ..trial import Trial

#: Held-out units of a schedule analysis: stretches of this many seconds (or 40 per record at
#: most), left out in interleaved folds so that every fold spans the schedule's range.
SCHEDULE_UNIT_S, MAX_SCHEDULE_UNITS = 2.0, 40
#: The fewest samples a cycle may have: the ensemble mean takes at least four per phase bin and ten
#: bins (:func:`limbstiff.cycles.mean_bins`).
MIN_CYCLE_SAMPLES = 40


@dataclass(frozen=True)
class ScheduleInput:
    """A trial prepared for a curve analysis.

    Parameters
    ----------
    against : {"phase", "schedule"}
    trial : Trial
        Cropped to whole cycles, the ensemble mean taken off (ensembles); unchanged (schedules).
    u : ndarray, shape (n,)
        The phase (0–1) or the schedule (its unit) at every sample of ``trial``.
    unit : str
        The schedule's unit ("1" for the phase).
    held_out : ndarray of int, shape (n,)
        Each sample's held-out unit: its cycle, or its stretch of the record.
    cycle : ndarray of int, shape (n,), or None
        Each sample's cycle (ensembles).
    how : str
        How the cycles were cut, or which column the schedule is.
    removed_share : float or None
        Share of the angle's variance that the ensemble mean held (ensembles).
    cycle_lengths_s : ndarray or None
        Each cycle's length, s.
    mean_bins : int or None
        Phase bins the ensemble mean was taken in (:func:`limbstiff.cycles.mean_bins`; ensembles).
    """

    against: str
    trial: Trial
    u: np.ndarray
    unit: str
    held_out: np.ndarray
    cycle: np.ndarray | None
    how: str
    removed_share: float | None = None
    cycle_lengths_s: np.ndarray | None = None
    mean_bins: int | None = None

    @property
    def n_cycles(self) -> int | None:
        return None if self.cycle is None else int(self.cycle.max()) + 1

    def to_dict(self) -> dict:
        out = {"against": self.against, "unit": self.unit, "how": self.how}
        if self.cycle is not None:
            lengths = self.cycle_lengths_s
            out.update(n_cycles=self.n_cycles, ensemble_mean_share_of_angle_variance=self.removed_share,
                       cycle_length_s={"median": float(np.median(lengths)), "min": float(lengths.min()),
                                       "max": float(lengths.max())})
        return out


def schedule_input(trial: Trial, protocol, *, where: str) -> ScheduleInput | None:
    """The trial prepared for the curve its protocol asks for (``[cycles]`` or a ``schedule``
    column), or None for a plain analysis.

    Raises
    ------
    TrialError
        Fewer than :data:`~limbstiff.cycles.MIN_CYCLES` whole cycles, no marker edges, no schedule
        column.
    """
    spec = protocol.cycles
    if spec is not None:
        return _ensemble(trial, spec, where=where)
    if "schedule" in protocol.columns or trial.schedule is not None:
        if trial.schedule is None:
            raise TrialError(where, "the protocol names a schedule column but the trial has none")
        lo, hi = np.percentile(trial.schedule, [1, 99])
        if not hi > lo:
            raise TrialError(where, "the schedule column does not vary (its 1st and 99th percentiles are equal): "
                                    "there is no operating point to relate the stiffness to")
        return _scheduled(trial)
    return None


def _split(trial: Trial, spec, *, where: str) -> cycles.CycleSplit:
    if spec.marker is not None:
        if trial.marker is None:
            raise TrialError(where, f"no marker column '{spec.marker}' to cut the cycles at")
        split = cycles.by_marker(trial.marker, header=spec.marker)
        if spec.marker == ENSEMBLE_MARKER:            # the files' own cycles, said as such
            split = dataclasses.replace(split, how=ENSEMBLE_HOW.format(split.n_cycles))
    else:
        split = cycles.by_period(trial.n_samples, sample_period=trial.sample_period, period_s=spec.period_s,
                                 start_s=spec.start_s)
    if split.n_cycles >= 1 and split.lengths().min() < MIN_CYCLE_SAMPLES:
        raise TrialError(where, f"the shortest cycle ({split.how}) has {int(split.lengths().min())} samples; a cycle "
                                f"needs at least {MIN_CYCLE_SAMPLES} to be told apart in phase (check [cycles])")
    if split.n_cycles < cycles.MIN_CYCLES:
        raise TrialError(where, f"{max(split.n_cycles, 0)} whole cycles ({split.how}); an ensemble needs at least "
                                f"{cycles.MIN_CYCLES} (check [cycles] in the protocol, or analyse without it)")
    return split


def _ensemble(trial: Trial, spec, *, where: str) -> ScheduleInput:
    split = _split(trial, spec, where=where)
    span = split.span
    phase = split.phase_of(trial.n_samples)[span]
    bins = cycles.mean_bins(split)
    changed = {}
    for name in ("angle", "torque", "elastic_torque"):
        values = getattr(trial, name)
        if values is not None:
            changed[name] = values[span] - cycles.ensemble_mean(values[span], phase, bins=bins)
    before = float(np.var(trial.angle[span]))
    share = 1.0 - float(np.var(changed["angle"])) / before if before > 0 else 0.0
    # a perturbation that repeats in every cycle goes with the mean: what is left has no motion,
    # which the analysis's motion checks and the curve's coverage say
    cropped = _cropped(trial, span, changed)
    local = split.shifted(span.start)
    cycle = local.cycle_of(cropped.n_samples)
    return ScheduleInput("phase", cropped, phase, "1", cycle, cycle, split.how, share,
                         split.lengths() * trial.sample_period, bins)


def _cropped(trial: Trial, span: slice, changed: dict) -> Trial:
    """The trial's samples ``span``, with ``changed`` arrays in place of its own."""
    fields = {}
    for name in ("time", "angle", "torque", "elastic_torque", "stiffness_true", "schedule", "marker", "bridged"):
        values = getattr(trial, name, None)
        fields[name] = changed.get(name, None if values is None else values[span])
    return dataclasses.replace(trial, **fields)


def _scheduled(trial: Trial) -> ScheduleInput:
    n = trial.n_samples
    units = int(min(MAX_SCHEDULE_UNITS, max(cycles.MIN_CYCLES, trial.duration // SCHEDULE_UNIT_S)))
    held_out = np.minimum((np.arange(n) * units) // n, units - 1)
    return ScheduleInput("schedule", trial, np.asarray(trial.schedule, dtype=float), trial.schedule_unit or "1",
                         held_out, None, "the recorded schedule")


def perturbation_frequency(angle: np.ndarray, prepared: ScheduleInput, *, fs: float) -> float:
    """The typical frequency of the motion the stiffness is identified from (the model's
    ``motion_hz``), Hz: the median frequency of the angle's spectrum
    (:func:`limbstiff.signals.motion_frequency`) once the operating point's own motion is taken
    off — on a schedule, the part of the angle that follows the schedule linearly (a swept
    position dominates the angle's power, and would set the model's windows to its slow sweep);
    in an ensemble, the angle's moving average over a cycle (a drift of the operating point)."""
    from scipy.ndimage import uniform_filter1d

    from ..signals import motion_frequency

    y = np.asarray(angle, dtype=float)
    if prepared.against == "schedule":
        x = np.column_stack([np.ones(len(y)), prepared.u])
        y = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
    else:
        window = int(round(float(np.median(prepared.cycle_lengths_s)) * fs))
        y = y - uniform_filter1d(y, max(window, 1), mode="nearest")
    return motion_frequency(y, fs)

