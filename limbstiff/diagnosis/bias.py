"""How much an effect biases the stiffness estimate: the trial with the effect removed, estimated again.

Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..band import limb_stiffness
from ..figure_draws import figure_course
from ..checks.model import angle_terms_on
from ..errors import LimbstiffError
from ..estimate import estimators
from ..filtered import filter_trial
from ..protocol import Protocol
from ..trial import Trial
from ..effects.channels import Channels
from ..effects.in_model import rival_columns, velocity_shape_miss
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


def analysis_stiffness(trial: Trial, result, ch: Channels, protocol: Protocol, inertia: float | None = None,
                       damping: float | None = None) -> float:
    """The median stiffness the analysis ``result`` would report for ``trial``, N·m/rad, with m and b
    ``inertia`` and ``damping`` (default those of ``ch``, the analysis's).

    The analysis's own model and summary, without its choices from the data: the trial filtered at
    its corner, the Kalman estimate at its noise levels (not refitted: a corrected trial then differs
    from the nominal one by the correction alone), the change with the angle within the cycle when
    the analysis added it (fitted as the analysis fits it, beside the velocity-driven torques when
    significant), the limb's stiffness when it undid a coupling, and the median over the
    informed samples of its trial-level figures (:func:`limbstiff.figure_draws.figure_course`). On the
    analysis's own trial, m and b it is the median the analysis reports (an ensemble's aside: its
    curve is not re-estimated here).
    """
    filtered = filter_trial(trial, protocol, corner_hz=ch.cutoff_hz)
    filtered = dataclasses.replace(filtered, motion_hz=ch.motion_hz)
    noise = None if result.fit is None else result.fit.noise
    if ch.mechanics == "none":
        est = estimators.kalman(filtered, noise=noise)
    else:
        est = estimators.kalman(filtered, noise=noise, inertia=ch.inertia if inertia is None else inertia,
                                damping=ch.damping if damping is None else damping)
    level = result.trial_level
    angle = None
    if level is not None and "angle" in level.sources:
        ident = result.identification
        miss = velocity_shape_miss(trial, filtered, est.steps, est.fit.noise, observable=result.observable,
                                   identified=ident is not None and not ident.given)
        angle = angle_terms_on(est.steps, est.fit.noise, motion_frequency=filtered.motion_hz,
                               beside=rival_columns(miss))
    samples, course = figure_course(filtered, est, result.observable, angle=angle)
    if limb_stiffness(result.coupling, est.stiffness, est.stiffness, est.stiffness)[0] is not est.stiffness:
        course = result.coupling.limb_stiffness(course)
    return float(np.median(course[samples.informed]))


def stiffness_change(trials, results, channels, protocol: Protocol, fitted_per_trial, *, nominal_stiffness,
                     baseline, mechanics=None, nominal_mechanics=None) -> StiffnessBias:
    """Median stiffness of each trial with the fitted effects removed, against the nominal one.

    The trial's recorded channels are corrected (the effect's torque taken off the recorded
    torque, or its recorded channel corrected, or m and b corrected), m and b moved as fitting the
    effects moves them when they are identified (``mechanics`` less ``nominal_mechanics``: per trial
    (m, b) of the diagnosis's model with the effects and without, or None), and the stiffness
    estimated again as the analysis estimates it (:func:`analysis_stiffness`). The corrected median is
    the nominal one (the analysis's) moved by the change the correction makes: ``baseline`` is
    :func:`analysis_stiffness` of the trial as recorded, equal to the nominal one but for an
    ensemble's curve.

    Returns
    -------
    StiffnessBias
        Per trial the nominal and corrected median and relative = nominal/corrected − 1 (the
        bias the effect puts on the nominal estimate), and the median of the relative biases.
    """
    per = {}
    mechanics = mechanics or [None] * len(trials)
    nominal_mechanics = nominal_mechanics or [None] * len(trials)
    for trial, res, ch, fitted, mech, mech0, nom, base in zip(trials, results, channels, fitted_per_trial, mechanics,
                                                            nominal_mechanics, nominal_stiffness, baseline):
        try:
            if any(not np.all(np.isfinite(np.atleast_1d(coef))) for _, _, coef in fitted):
                raise LimbstiffError("the effect's amplitude could not be fitted")
            corr = remove(ch, fitted)
            if mech is not None and mech0 is not None:
                corr = dataclasses.replace(corr, inertia=corr.inertia + mech[0] - mech0[0],
                                           damping=corr.damping + mech[1] - mech0[1])
            if ch.mechanics != "none" and not (corr.inertia > 0 and corr.damping > 0):
                raise LimbstiffError(f"the corrected inertia ({corr.inertia:.3g}) or damping ({corr.damping:.3g}) "
                                     "is not positive")
            new = nom + analysis_stiffness(_corrected_trial(trial, ch, corr), res, ch, protocol, corr.inertia,
                                           corr.damping) - base
        except LimbstiffError as exc:
            per[trial.name] = TrialBias(nominal=nom, corrected=None, relative=None, error=str(exc))
            continue
        per[trial.name] = TrialBias(nominal=nom, corrected=new, relative=nom / new - 1.0 if new else None)
    rel = [v.relative for v in per.values() if v.relative is not None]
    return StiffnessBias(per_trial=per, median_relative=float(np.median(rel)) if rel else None)
