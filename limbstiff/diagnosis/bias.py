"""How much an effect biases the stiffness estimate: the trial with the effect removed, estimated again.

Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import LimbstiffError
from ..estimate import estimators
from ..estimate.observer import informed_samples
from ..filtered import filter_trial
from ..protocol import Protocol
from ..trial import Trial
from ..effects.channels import Channels
from ..effects.kinds import remove
from .parts import StiffnessBias, TrialBias


def _corrected_trial(trial: Trial, ch: Channels, corr) -> Trial:
    """The trial with the recorded channels of a :class:`~.kinds.Correction` put in."""
    changes = {}
    if corr.angle is not None:
        changes["angle"] = corr.angle
    if corr.torque is not None:
        changes["torque" if trial.torque is not None and ch.mechanics != "none" else "elastic_torque"] = corr.torque
    return dataclasses.replace(trial, **changes) if changes else trial


def median_stiffness(trial: Trial, result, ch: Channels, protocol: Protocol, inertia: float | None = None,
                     damping: float | None = None) -> float:
    """Median Kalman stiffness of ``trial`` over ``result``'s informed samples, N·m/rad.

    The trial is filtered at the analysis's corner and the Kalman estimator run with m and b
    fixed (``inertia``, ``damping``; default those of ``ch``): the stiffness the analysis would
    give with them, without its choice of corner, coupling test and checks, so that the nominal
    and a corrected trial differ only by the correction.
    """
    filtered = filter_trial(trial, protocol, corner_hz=ch.cutoff_hz)
    if ch.mechanics == "none":
        est = estimators.kalman(filtered)
    else:
        est = estimators.kalman(filtered, inertia=ch.inertia if inertia is None else inertia,
                                damping=ch.damping if damping is None else damping)
    return float(np.median(est.stiffness[informed_samples(result.observable)]))


def stiffness_change(trials, results, channels, protocol: Protocol, fitted_per_trial, *, nominal_stiffness,
                     mechanics=None) -> StiffnessBias:
    """Median stiffness of each trial with the fitted effects removed, against the nominal one.

    The trial's recorded channels are corrected (the effect's torque taken off the recorded
    torque, or its recorded channel corrected, or m and b corrected), m and b fixed — to the
    nominal values, or to those fitted with the effects when they are identified (``mechanics``:
    per trial (m, b) or None) — and the stiffness estimated again (:func:`median_stiffness`).

    Returns
    -------
    StiffnessBias
        Per trial the nominal and corrected median and relative = nominal/corrected − 1 (the
        bias the effect puts on the nominal estimate), and the median of the relative biases.
    """
    per = {}
    mechanics = mechanics or [None] * len(trials)
    for trial, res, ch, fitted, mech, nom in zip(trials, results, channels, fitted_per_trial, mechanics,
                                                 nominal_stiffness):
        try:
            if any(not np.all(np.isfinite(np.atleast_1d(coef))) for _, _, coef in fitted):
                raise LimbstiffError("the effect's amplitude could not be fitted")
            corr = remove(ch, fitted)
            if mech is not None:
                corr = dataclasses.replace(corr, inertia=corr.inertia - ch.inertia + mech[0],
                                           damping=corr.damping - ch.damping + mech[1])
            if ch.mechanics != "none" and not (corr.inertia > 0 and corr.damping > 0):
                raise LimbstiffError(f"the corrected inertia ({corr.inertia:.3g}) or damping ({corr.damping:.3g}) "
                                     "is not positive")
            new = median_stiffness(_corrected_trial(trial, ch, corr), res, ch, protocol, corr.inertia, corr.damping)
        except LimbstiffError as exc:
            per[trial.name] = TrialBias(nominal=nom, corrected=None, relative=None, error=str(exc))
            continue
        per[trial.name] = TrialBias(nominal=nom, corrected=new, relative=nom / new - 1.0 if new else None)
    rel = [v.relative for v in per.values() if v.relative is not None]
    return StiffnessBias(per_trial=per, median_relative=float(np.median(rel)) if rel else None)
