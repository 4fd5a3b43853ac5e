"""The :class:`Trial`: one recording in SI units on a uniform time base.

A trial is what every estimator works on. It is built by :func:`limbstiff.files.read_trial`
(from a file) or by :mod:`limbstiff.simulate` (from a scenario); both check it the same way,
so the processing modules can take its invariants for granted: uniform, strictly increasing
time; finite samples; SI units; at least one of ``torque`` and ``elastic_torque``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Literal, Mapping

import numpy as np

from .errors import TrialError
from .frozen import FrozenDict
from .units import SI_NAMES, UNITS, free_unit_clash

Kind = Literal["rotational", "translational"]

#: SI units of each quantity, by kind of joint.
SI_UNITS: Mapping[Kind, Mapping[str, str]] = MappingProxyType({
    "rotational": MappingProxyType({
        "time": "s", "angle": "rad", "torque": "N·m", "elastic_torque": "N·m",
        "stiffness": "N·m/rad", "inertia": "kg·m²", "damping": "N·m·s/rad",
    }),
    "translational": MappingProxyType({
        "time": "s", "angle": "m", "torque": "N", "elastic_torque": "N",
        "stiffness": "N/m", "inertia": "kg", "damping": "N·s/m",
    }),
})

#: Fewest samples a trial may have: the derivative filters and the observer need a few
#: cycles of motion to say anything.
MIN_SAMPLES = 64
#: Shortest trial, s: under it no motion cycle of a limb fits.
MIN_DURATION = 0.5


@dataclass(frozen=True)
class Trial:
    """One recording of a joint (or a translational spring), in SI units.

    Parameters
    ----------
    name : str
        Trial name, normally the file stem.
    time : ndarray, shape (n,), s
        Uniform, strictly increasing sample times.
    angle : ndarray, shape (n,), rad (m for translational trials)
        Joint angle y.
    torque : ndarray, shape (n,), N·m (N), or None
        External torque applied *to* the joint, positive towards positive angle.
    elastic_torque : ndarray, shape (n,), N·m (N), or None
        Torque measured on the elastic element itself; when present the direct variant of
        the observer applies.
    stiffness_true : ndarray, shape (n,), N·m/rad (N/m), or None
        Reference stiffness, for validation only.
    kind : {"rotational", "translational"}
        Rotational joint (angle/torque) or translational spring (position/force).
    metadata : Mapping[str, str]
        The ``# key: value`` lines of the file (subject, side, joint, date…).
    source : str or None
        Path of the file the trial was read from.
    source_sha256 : str or None
        SHA-256 of that file's bytes.
    warnings : tuple of str
        What was noticed while reading (resampling, ignored columns…).
    bridged : ndarray of bool, shape (n,), or None
        True where the samples were interpolated across a gap in the file's time column: the
        analysis treats them as not informed by motion.
    schedule : ndarray, shape (n,), or None
        A recorded variable the stiffness depends on (an operating position, an EMG envelope, a
        commanded torque), in SI units or in a free unit the unit table does not know.
    schedule_unit : str or None
        The unit ``schedule`` is in: an SI unit (``"rad"``, ``"m"``, ``"N·m"``…) or the free unit
        as given (``"%MVC"``, ``"V"``); None exactly when there is no schedule.
    marker : ndarray, shape (n,), or None
        The raw values of the trigger (event) column whose rising edges start the movement cycles.
    units_written : Mapping[str, str]
        The unit each quantity was written in, in the file or its protocol, before conversion
        (``{"angle": "rad", "torque": "Nm"}``): what a unit advice must not name as the fix. Empty
        for a trial not read from a file.
    """

    name: str
    time: np.ndarray
    angle: np.ndarray
    torque: np.ndarray | None = None
    elastic_torque: np.ndarray | None = None
    stiffness_true: np.ndarray | None = None
    kind: Kind = "rotational"
    metadata: Mapping[str, str] = field(default_factory=dict)
    source: str | None = None
    source_sha256: str | None = None
    warnings: tuple[str, ...] = ()
    bridged: np.ndarray | None = None
    schedule: np.ndarray | None = None
    schedule_unit: str | None = None
    marker: np.ndarray | None = None
    units_written: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self):
        where = self.source or self.name
        if self.kind not in SI_UNITS:
            raise TrialError(where, f"unknown kind {self.kind!r} (rotational or translational)")
        if self.torque is None and self.elastic_torque is None:
            raise TrialError(where, "no torque or force column (external or elastic)")
        n = len(self.time)
        for label in ("time", "angle", "torque", "elastic_torque", "stiffness_true", "schedule", "marker"):
            values = getattr(self, label)
            if values is None:
                continue
            values = np.asarray(values, dtype=float)
            values.setflags(write=False)
            object.__setattr__(self, label, values)
            if values.ndim != 1 or len(values) != n:
                raise TrialError(where, f"column '{label}' has {values.size} samples, time has {n}")
            if not np.all(np.isfinite(values)):
                k = int(np.flatnonzero(~np.isfinite(values))[0])
                raise TrialError(where, f"'{label}' is not finite at sample {k}")
        if (self.schedule is None) != (self.schedule_unit is None):
            raise TrialError(where, "'schedule' and 'schedule_unit' go together: give both or neither")
        if self.schedule_unit is not None:
            _check_schedule_unit(where, self.schedule_unit)
        if n < MIN_SAMPLES:
            raise TrialError(where, f"trial too short: {n} samples (at least {MIN_SAMPLES} needed)")
        dt = np.diff(self.time)
        if np.any(dt <= 0):
            k = int(np.flatnonzero(dt <= 0)[0]) + 1
            raise TrialError(where, f"time is not strictly increasing at sample {k}")
        if np.ptp(dt) > 1e-6 * np.median(dt):
            raise TrialError(where, "time base is not uniform (resample it first)")
        if self.bridged is not None:
            mask = np.asarray(self.bridged, dtype=bool)
            if mask.shape != (n,):
                raise TrialError(where, f"'bridged' has {mask.size} samples, time has {n}")
            mask.setflags(write=False)
            object.__setattr__(self, "bridged", mask)
        object.__setattr__(self, "metadata", FrozenDict(self.metadata))
        object.__setattr__(self, "units_written", FrozenDict(self.units_written))
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return len(self.time)

    @property
    def sample_period(self) -> float:
        """Sampling period Ts, s."""
        return float((self.time[-1] - self.time[0]) / (len(self.time) - 1))

    @property
    def fs(self) -> float:
        """Sampling rate, Hz."""
        return 1.0 / self.sample_period

    @property
    def duration(self) -> float:
        """Time from first to last sample, s."""
        return float(self.time[-1] - self.time[0])

    @property
    def variant(self) -> Literal["direct", "external"]:
        """Observer variant the data allow: ``direct`` when the elastic torque is measured."""
        return "direct" if self.elastic_torque is not None else "external"

    def segment(self, start: int, stop: int) -> "Trial":
        """Samples ``start`` … ``stop`` − 1 as a trial of their own (same name, source and metadata)."""
        part = slice(start, stop)
        return replace(self, time=self.time[part], angle=self.angle[part],
                       **{k: None if getattr(self, k) is None else getattr(self, k)[part]
                          for k in ("torque", "elastic_torque", "stiffness_true", "bridged", "schedule", "marker")})

    @property
    def units(self) -> Mapping[str, str]:
        """SI units of every quantity of this trial (and of the results derived from it)."""
        return SI_UNITS[self.kind]


def _check_schedule_unit(where: str, unit) -> None:
    """A schedule's unit is an SI unit of the table (``rad``, ``N·m``) or a free one it does not
    know (``%MVC``): not a non-SI unit of the table (``deg``), nor one it knows by another case."""
    if not (isinstance(unit, str) and unit.strip()):
        raise TrialError(where, f"'schedule_unit' must be a unit, not {unit!r}")
    known = UNITS.get(unit)
    if known is not None and known.factor != 1.0:
        raise TrialError(where, f"'schedule' must be in SI units ({SI_NAMES[known.dimension]}), not '{unit}'")
    clash = free_unit_clash(unit)
    if clash:
        raise TrialError(where, f"'schedule_unit' '{unit}' is not in the unit table, '{clash}' is")
