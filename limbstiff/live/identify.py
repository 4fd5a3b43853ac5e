"""What the live estimate must learn from the record so far: the corner, m and b, the noise levels.

:func:`identify_live` runs the offline analysis's own steps on the samples received so far — the
corner where the model predicts the torque best (:func:`limbstiff.filtering.filter_for_model`),
m and b with their emcee posterior (:func:`~limbstiff.mechanics.identification.identify_mechanics`)
— then fits the model's noise levels by maximum likelihood on the causal chain's own steps (its
filter is causal, so its noise is coloured differently from the zero-phase chain's) and runs the
chain over the record, so that the estimator it returns carries on from the last sample given.
It also smooths the record as the offline analysis does, for the live ``hindsight`` check. It is
slow (seconds): ``limbstiff stream`` calls it in a worker process while the live estimate goes on
with the model it has (:mod:`limbstiff.live.session`). Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..filtering import filter_for_model
from ..settings import OBSERVABLE_PERIODS
from ..estimate import estimators
from ..estimate.kalman import data_guess, fit_noise_levels
from ..filtered import filter_trial
from ..mechanics.identification import identify_mechanics
from ..protocol import Protocol
from ..statespace.steps import initial_cov, model_steps
from ..trial import Trial
from .checks import window_s
from .estimator import LiveEstimator, LiveModel

#: Seconds of the most recent record the live model is identified from: m and b are constant, so
#: ten minutes pin them down, and the cost and the data sent to the worker stop growing.
LONGEST_RECORD_S = 600.0
#: Seconds of the most recent record the noise levels are refitted on between identifications
#: (:func:`refit_live`): the walk rates are the recent record's.
REFIT_RECORD_S = 60.0
#: Share of the record's model steps at its start left out of the typical variance (the diffuse
#: start's wide band).
START_SHARE = 0.2


@dataclass(frozen=True)
class LiveIdentification:
    """The live model identified on a record, and the estimator carried to its last sample.

    Parameters
    ----------
    model : LiveModel
    estimator : LiveEstimator
        Its state is at the record's last sample: feed it the samples after that.
    samples : int
        Samples of the record used (the last ``samples`` of it).
    variant : {"external", "direct"}
    warnings : tuple of str
        The identification's warnings (and the trial's).
    smoothed : ndarray, shape (k,), or None
        The offline smoothed stiffness over the record's last checks window
        (:func:`~limbstiff.live.checks.window_s`) and the memory and filter edge after it, ending at
        its last sample; NaN over that memory and edge, where it has no more future than the live
        estimate (the ``hindsight`` check).
    """

    model: LiveModel
    estimator: LiveEstimator
    samples: int
    variant: str
    warnings: tuple[str, ...]
    smoothed: np.ndarray | None = None


def _trial(name: str, fs: float, angle: np.ndarray, torque: np.ndarray, variant: str) -> Trial:
    time = np.arange(len(angle)) / fs
    key = "elastic_torque" if variant == "direct" else "torque"
    return Trial(name=name, time=time, angle=np.asarray(angle, dtype=float), **{key: np.asarray(torque, dtype=float)})


def _fit_noise(model: LiveModel, angle: np.ndarray, torque: np.ndarray, guess) -> LiveModel:
    """The noise levels by maximum likelihood on the causal chain's steps over the record, for the
    filter the model runs: with its fading memory (:attr:`LiveModel.fading`)."""
    rows = LiveEstimator(model).push(angle, torque).rows
    steps = rows[np.isfinite(rows[:, 5])]
    z, y, g = steps[:, 7], steps[:, 8], steps[:, 9]
    increments = np.diff(y, prepend=y[0])
    cov0 = (model.initial_cov[0], 0.0, model.initial_cov[1])
    noise, _ = fit_noise_levels(increments, z, step=model.decimation / model.fs, deflection=g,
                                initial_mean=(float(z[0]), 0.0), initial_cov=cov0, guess=guess,
                                motion_frequency=model.motion_hz, fading=model.fading)
    return replace(model, noise=noise)


def identify_live(angle: np.ndarray, torque: np.ndarray, *, fs: float, protocol: Protocol | None = None,
                  seed: int = 0, name: str = "live", variant: str | None = None,
                  memory_periods: float | None = None) -> LiveIdentification:
    """The live model from the record so far, and the estimator run over it.

    Parameters
    ----------
    angle, torque : ndarray, shape (n,)
        The record so far in SI units (the external torque, or the elastic one for the direct
        variant), uniformly sampled at ``fs``; only its last :data:`LONGEST_RECORD_S` are used.
    fs : float, Hz
    protocol : Protocol, optional
        Corner, m and b when it gives them, priors, ``ci_level``.
    seed : int
        Seed of the emcee posterior.
    name : str
        The trial's name in error messages.
    variant : {"external", "direct"}, optional
        Default: the protocol's, else external.
    memory_periods : float, optional
        The live estimate's fading memory (:attr:`LiveModel.memory_s`) in motion periods; the noise
        levels are fitted without it.

    Returns
    -------
    LiveIdentification

    Raises
    ------
    TrialError
        When the record cannot be analysed (too short, no motion, m or b not identifiable).
    """
    protocol = protocol or Protocol()
    keep = min(len(angle), int(LONGEST_RECORD_S * fs))
    angle, torque = np.asarray(angle[-keep:], dtype=float), np.asarray(torque[-keep:], dtype=float)
    variant = variant or ("direct" if protocol.variant == "direct" else "external")
    trial = _trial(name, fs, angle, torque, variant)
    filtered, _ = filter_for_model(trial, protocol)
    cov = np.zeros((2, 2))
    m = b = 0.0
    warnings: tuple[str, ...] = ()
    noise = None
    if filtered.variant == "external":
        ident = identify_mechanics(filtered, protocol, rng=np.random.default_rng(seed), seed=seed, where=name)
        m, b, cov, noise, warnings = (ident.inertia.median, ident.damping.median, np.asarray(ident.covariance),
                                      ident.noise_levels, ident.warnings)
    p11, _, p22 = initial_cov(angle, torque)
    model = LiveModel(fs=fs, corner_hz=filtered.cutoff_hz, motion_hz=filtered.motion_hz, noise=noise,
                      inertia=float(m), damping=float(b), covariance=cov, initial_cov=(p11, p22),
                      typical_variance=None, ci_level=protocol.ci_level, identified_s=keep / fs,
                      smoother_noise=noise)
    if noise is None:      # the direct variant: no identification fitted them
        noise = data_guess(model_steps(angle, torque, sample_period=1 / fs, decimation=model.decimation, edge=0,
                                       motion_frequency=model.motion_hz))
        model = replace(model, noise=noise)
    est = _fitted_estimator(model, angle, torque, noise, memory_periods)
    return LiveIdentification(model=est.model, estimator=est, samples=keep, variant=filtered.variant,
                              warnings=tuple(trial.warnings) + tuple(warnings),
                              smoothed=_unless_it_fails(lambda: _smoothed_tail(filtered, est.model)))


def _unless_it_fails(course):
    """``course()``, or None when it cannot be made: the look back is the ``hindsight`` check's,
    never a reason for an identification or a refit to fail."""
    try:
        return course()
    except Exception:        # any: the live estimate, the refit and the session must go on
        return None


def _smoothed_tail(filtered, model: LiveModel) -> np.ndarray:
    """The analysis's Kalman/RTS stiffness over the record (zero-phase, with the identification's
    m, b and noise levels; the direct variant fits its own): a checks window and then the last
    memory and filter edge, NaN over those."""
    external = filtered.variant == "external"
    mech = {"inertia": model.inertia, "damping": model.damping, "noise": model.smoother_noise} if external else {}
    course = estimators.kalman(filtered, **mech).stiffness
    memory_s = model.memory_s if model.memory_s is not None else OBSERVABLE_PERIODS / model.motion_hz
    unjudged = filtered.edge + int(round(memory_s * model.fs))
    tail = course[-(int(window_s(model.motion_hz) * model.fs) + unjudged):].copy()
    tail[max(len(tail) - unjudged, 0):] = np.nan
    return tail


def _fitted_estimator(model: LiveModel, angle, torque, guess, memory_periods) -> LiveEstimator:
    """The memory set, the noise levels fitted from ``guess`` for the filter with that memory, and the
    estimator run over the record (its typical variance from the record's steps after the first
    :data:`START_SHARE`)."""
    if memory_periods is not None:
        model = replace(model, memory_s=memory_periods / model.motion_hz)
    model = _fit_noise(model, angle, torque, guess)
    est = LiveEstimator(model)
    variance = est.push(angle, torque).rows[:, 4]
    start = int(START_SHARE * len(variance))
    finite = variance[start:][np.isfinite(variance[start:])]
    est.retuned(replace(model, typical_variance=float(np.median(finite)) if finite.size else None))
    return est


def refit_live(angle: np.ndarray, torque: np.ndarray, *, previous: LiveModel,
               memory_periods: float | None = None, variant: str = "external",
               protocol: Protocol | None = None) -> LiveIdentification:
    """The noise levels refitted on the last :data:`REFIT_RECORD_S` of the record, the corner, m and
    b kept: what the live model does between identifications, so that its stiffness walk follows
    the record (fitted on a first stretch where the stiffness held still, the walk is too small to
    follow a later change: on the independent simulator's ramp 7.8 % median error with the first
    5 s's noise levels, 1.2 % with those of the whole trial).

    Parameters
    ----------
    angle, torque : ndarray, shape (n,)
        The record so far (SI units).
    previous : LiveModel
        The model whose corner, m, b and their covariance are kept (and whose noise levels start the fit).
    memory_periods : float, optional
    variant : {"external", "direct"}
    protocol : Protocol, optional
        The filter's settings for the smoothed course (the ``hindsight`` check), at the model's corner.

    Returns
    -------
    LiveIdentification
    """
    keep = min(len(angle), int(REFIT_RECORD_S * previous.fs))
    angle, torque = np.asarray(angle[-keep:], dtype=float), np.asarray(torque[-keep:], dtype=float)
    p11, _, p22 = initial_cov(angle, torque)
    model = replace(previous, initial_cov=(p11, p22), typical_variance=None, memory_s=None,
                    identified_s=keep / previous.fs)
    est = _fitted_estimator(model, angle, torque, previous.noise, memory_periods)
    def course():
        filtered = filter_trial(_trial("live", previous.fs, angle, torque, variant), protocol or Protocol(),
                                corner_hz=previous.corner_hz)
        return _smoothed_tail(filtered, est.model)
    return LiveIdentification(model=est.model, estimator=est, samples=keep, variant=variant, warnings=(),
                              smoothed=_unless_it_fails(course))
