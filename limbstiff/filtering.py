"""The trial filtered for the model, its corner decided once: the scan's, lowered by a coupling.

:func:`filter_for_model` filters at the corner where the model predicts the torque best
(:func:`limbstiff.bandwidth.scan_corners`); :func:`filtered_for_analysis` then looks for a compliant
coupling between limb and device (:func:`limbstiff.coupling.detect_coupling`) and, when one is
found, lowers the corner to :data:`COUPLING_CORNER` of its resonance. Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from . import bandwidth
from .coupling import CouplingFit, detect_coupling
from .filtered import Filtered, filter_trial
from .protocol import Protocol
from .scheduled import run as scheduled
from .trial import Trial

#: With a coupling found, the corner chosen from the data is lowered to this share of its
#: resonance: the one-body model then sees the quasi-static springs in series that
#: :meth:`CouplingFit.limb_stiffness` undoes (measured on the simulated coupling: median error
#: 3 % at 20 Hz and 0.0 % at 35 Hz for corners of 0.3–0.7 of the resonance, against 22 % and
#: 0.7 % at the corner the scan chose above it).
COUPLING_CORNER = 0.5


@dataclass(frozen=True)
class ModelSignals:
    """The trial's signals as the model sees them.

    Parameters
    ----------
    filtered : Filtered
        Filtered at the corner decided; for a curve analysis its motion frequency is the
        perturbation's (:func:`scheduled.perturbation_frequency`).
    scan : bandwidth.CornerScan or None
        The corner scan, when the corner was left to the data.
    coupling : CouplingFit or None
        The coupling looked for (external variant).
    """

    filtered: Filtered
    scan: bandwidth.CornerScan | None
    coupling: CouplingFit | None


def filter_for_model(trial: Trial, protocol: Protocol) -> tuple[Filtered, bandwidth.CornerScan | None]:
    """The trial filtered at the corner where the model predicts the torque best
    (:func:`bandwidth.scan_corners`), or at the protocol's corner when it gives one."""
    if not bandwidth.scans(protocol):
        return filter_trial(trial, protocol), None
    scan, filtered = bandwidth.scan_corners(trial, protocol)
    return (filtered if filtered is not None else filter_trial(trial, protocol, corner_hz=scan.chosen_hz)), scan


def coupling_of(trial: Trial, filtered: Filtered) -> CouplingFit | None:
    """A compliant coupling between limb and device, from the recorded dynamic stiffness
    (external variant: the device's torque against its angle)."""
    if filtered.variant != "external":
        return None
    return detect_coupling(trial.angle, trial.torque, trial.fs, motion_hz=filtered.motion_hz,
                           signal_edge_hz=filtered.bandwidth.signal_edge_hz)


def filtered_for_analysis(trial: Trial, protocol: Protocol,
                          prepared: scheduled.ScheduleInput | None = None) -> ModelSignals:
    """The trial filtered for the model at the corner decided once: the scan's
    (:func:`filter_for_model`), lowered to :data:`COUPLING_CORNER` of a coupling's resonance when
    the scan chose it and a coupling was found."""
    filtered, scan = filter_for_model(trial, protocol)
    coupling = coupling_of(trial, filtered)
    if scan is not None and coupling is not None and coupling.found:
        corner = COUPLING_CORNER * coupling.resonance_hz
        if filtered.cutoff_hz is None or filtered.cutoff_hz > corner:
            filtered = filter_trial(trial, protocol, corner_hz=corner)
    if prepared is not None:
        filtered = dataclasses.replace(filtered, motion_hz=scheduled.perturbation_frequency(
            filtered.angle, prepared, fs=filtered.fs))
    return ModelSignals(filtered, scan, coupling)
