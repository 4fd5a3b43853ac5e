"""Stiffness analysis of one trial: filter → (inertia, damping) → estimator → result.

:func:`analyze` is the library call behind ``limbstiff analyze``. It resolves the settings
(protocol, then explicit arguments), derives what the protocol leaves open from the trial's
own data (filter bandwidth, observer gain, velocity threshold, observability window, and —
for the external-torque variant — inertia and damping), runs the estimator and returns a
:class:`~limbstiff.result.StiffnessResult`. No file is written here; a trial or protocol given as
a path is read through :mod:`limbstiff.files`.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Sequence

import numpy as np
from scipy import stats

from . import bandwidth
from .blas_threads import one_blas_thread
from .coupling import MAX_CORRECTION, CouplingFit, detect_coupling
from .checks import check_analysis
from .checks.analysis import sign_hint
from .checks.model import angle_terms_on
from .checks.reflex import ReflexShift, reflex_check
from .checks.units import implausible_inertia, plausible, units_checks
from .checks.verdict import ModelChecks
from .effects.in_model import ShapeProfile, filtered_without, reflex_probe, reflex_shift, terms_for
from .errors import TrialError
from .estimate import estimators, observer
from .estimate.angle_terms import AngleTerms
from .estimate.course_draws import course_deviations
from .estimate.informed import band_informed, uninformed_band
from .statespace.noise import NoiseLevels
from .statespace.steps import kalman_decimation, step_index
from .filtered import Filtered, filter_trial
from .files import read_trial
from .mechanics.effect_terms import EffectTerms, joined
from .mechanics.identification import Identification, identify_mechanics
from .mechanics.likelihood import MechanicsFit
from .protocol import Protocol, load_protocol
from .result import DerivedSettings, StiffnessResult, result_units, software
from .scheduled import run as scheduled
from .trial import Trial
from .trial_level import FigureSamples, TrialLevel, course_draws_for, figure_samples, trial_level

#: Default memory of the observer, as a fraction of the range of motion: by (8) the estimate
#: forgets its past as exp(−α·path), so 1/α is the path over which it averages the local slope.
MEMORY_FRACTION_OF_RANGE = 1 / 20
#: Speeds below this multiple of the velocity noise level count as no motion.
VELOCITY_NOISE_MULTIPLE = 3.0
#: Observability window, in periods of the typical motion frequency.
OBSERVABLE_PERIODS = 2.0


def range_of_motion(angle: np.ndarray) -> float:
    """Span of the central 95 % of the angle, rad (m): robust to spikes and drift ends."""
    return float(np.subtract(*np.percentile(angle, [97.5, 2.5])))


def default_gain(angle: np.ndarray) -> float:
    """Observer gain α from the data: memory 1/α of :data:`MEMORY_FRACTION_OF_RANGE` of the range, 1/rad (1/m)."""
    return 1.0 / (MEMORY_FRACTION_OF_RANGE * range_of_motion(angle))


#: With a coupling found, the corner chosen from the data is lowered to this share of its
#: resonance: the one-body model then sees the quasi-static springs in series that
#: :meth:`CouplingFit.limb_stiffness` undoes (measured on the simulated coupling: median error
#: 3 % at 20 Hz and 0.0 % at 35 Hz for corners of 0.3–0.7 of the resonance, against 22 % and
#: 0.7 % at the corner the scan chose above it).
COUPLING_CORNER = 0.5
#: A lower corner that predicts this much more of the torque (share of its variance) than the
#: spectral one is said in the warnings: the torque above it holds what the model cannot explain.
CORNER_GAIN_WARNING = 0.05


def _where(trial: Trial) -> str:
    return trial.source or trial.name


def filter_for_model(trial: Trial, protocol: Protocol) -> tuple[Filtered, bandwidth.CornerScan | None]:
    """The trial filtered at the corner where the model predicts the torque best
    (:func:`bandwidth.scan_corners`), or at the protocol's corner when it gives one."""
    if not bandwidth.scans(protocol):
        return filter_trial(trial, protocol), None
    scan, filtered = bandwidth.scan_corners(trial, protocol)
    return (filtered if filtered is not None else filter_trial(trial, protocol, corner_hz=scan.chosen_hz)), scan


@one_blas_thread
def identify_trial(trial: Trial, protocol: Protocol | None = None, *, seed: int = 0) -> Identification:
    """Identify inertia and damping of one trial only (``limbstiff identify``).

    Returns
    -------
    Identification
        Its ``posterior`` is None when both are given.

    Raises
    ------
    TrialError
        For a direct-variant trial (no external torque), or when m or b is not identifiable.
    """
    protocol = protocol or Protocol()
    found = plausible(trial, protocol)
    filtered, _ = filter_for_model(trial, protocol)
    if filtered.variant != "external":
        raise TrialError(_where(trial), "inertia and damping are identified from the external "
                                        "torque; this trial has only the elastic torque (direct variant)")
    ident = identify_mechanics(filtered, protocol, rng=np.random.default_rng(seed), seed=seed, where=_where(trial))
    found = implausible_inertia(trial, protocol, ident, found)
    return dataclasses.replace(ident, warnings=ident.warnings + tuple(f.message for f in found)) if found else ident


def identification_summary(trial: Trial, ident: Identification, *, ci_level: float, seed: int) -> dict:
    """The content of ``posterior.json`` (JSON-ready)."""
    post = ident.posterior
    return {"trial": trial.name, "source": trial.source, "source_sha256": trial.source_sha256,
            "ci_level": ci_level, "inertia": ident.inertia.to_dict(), "damping": ident.damping.to_dict(),
            "covariance": ident.covariance.tolist(), "units": result_units(trial.units),
            "identification": ident.to_dict(), "mcmc": None if post is None else post.diagnostics.to_dict(),
            "seed": seed, "warnings": list(trial.warnings) + list(ident.warnings),
            "software": software(), "metadata": dict(trial.metadata)}


def derive_settings(filtered: Filtered, protocol: Protocol, *, where: str = "trial") -> DerivedSettings:
    """Observer gain, velocity threshold and observability window from the data (or the protocol)."""
    range_ = range_of_motion(filtered.angle)
    if not range_ > 0:
        raise TrialError(where, "no motion: the angle does not change")
    return DerivedSettings(observer_gain=protocol.observer_gain or default_gain(filtered.angle),
                           discretisation=protocol.discretisation, range_of_motion=range_,
                           velocity_threshold=VELOCITY_NOISE_MULTIPLE * filtered.velocity_noise,
                           observable_window_s=OBSERVABLE_PERIODS / filtered.motion_hz)


def _mechanics(filtered: Filtered, protocol: Protocol, *, seed: int, where: str,
               effects: EffectTerms | None = None, basis: EffectTerms | None = None,
               fit: MechanicsFit | None = None) -> Identification | None:
    """m and b for the external variant (with the check of the protocol's expected range)."""
    if filtered.variant != "external":
        return None
    try:
        ident = identify_mechanics(filtered, protocol, rng=np.random.default_rng(seed), seed=seed, where=where,
                                   effects=effects, basis=basis, fit=fit)
    except TrialError as exc:
        hint = sign_hint(filtered)
        raise (TrialError(exc.source, f"{exc.problem}; {hint}") if hint else exc) from None
    return dataclasses.replace(ident, expected_inertia=protocol.inertia_range)


def _check_noise(filtered: Filtered, estimate: estimators.Estimate, ident: Identification | None) -> NoiseLevels:
    """The Kalman model's noise levels for the checks: the estimator's, the identification's, or
    (observers on the direct variant) fitted here."""
    if estimate.fit.noise is not None:
        return estimate.fit.noise
    if ident is not None and ident.noise_levels is not None:
        return ident.noise_levels
    mech = {} if ident is None else {"inertia": ident.inertia.median, "damping": ident.damping.median}
    return estimators.kalman(filtered, **mech).fit.noise


def _estimate(filtered: Filtered, protocol: Protocol, derived: DerivedSettings,
              ident: Identification | None, extra: np.ndarray | None = None,
              noise: NoiseLevels | None = None) -> estimators.Estimate:
    mech = {} if ident is None else {"inertia": ident.inertia.median, "damping": ident.damping.median}
    if protocol.estimator == "kalman":
        # the noise levels fitted with m and b (one likelihood for both), when they were fitted
        noise = noise if noise is not None else (None if ident is None else ident.noise_levels)
        return estimators.kalman(filtered, noise=noise, extra_regressors=extra, **mech)
    return estimators.observers(filtered, smoothed=protocol.estimator == "observer-smoothed",
                                gain=derived.observer_gain, velocity_threshold=derived.velocity_threshold,
                                discretisation=protocol.discretisation, **mech)


def _band(estimate: estimators.Estimate, ident: Identification | None, coupling: CouplingFit | None,
          observable: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stiffness and its ``level`` band, with the uncertainty of m, b and the effects'
    amplitudes carried, the limb's when a coupling was found, unbounded where uninformed."""
    z = float(stats.norm.ppf(0.5 + level / 2))
    half = z * np.sqrt(np.maximum(estimate.variance_with(None if ident is None else ident.coefficient_covariance),
                                  0.0))
    stiffness, lo, hi = limb_stiffness(coupling, estimate.stiffness, estimate.stiffness - half,
                                       estimate.stiffness + half)
    lo, hi = uninformed_band(lo, hi, observable)
    return stiffness, lo, hi


def _estimate_and_probe(trial: Trial, filtered: Filtered, protocol: Protocol, derived: DerivedSettings,
                        ident: Identification | None,
                        terms: EffectTerms | None) -> tuple[estimators.Estimate, ShapeProfile | None]:
    """The estimate, with the sensitivity to the terms in the model (effects, a curve's weights)
    and, last, to the reflex the ``reflex`` check probes for (:func:`reflex_probe`; at the
    estimator's noise levels when m and b are given, which then runs twice)."""
    def extra(probe):
        rows = ([terms.columns] if terms is not None else []) + ([probe.column[None]] if probe is not None else [])
        return np.vstack(rows) if rows else None

    probe = reflex_probe(trial, filtered, protocol, ident, None if ident is None else ident.noise_levels)
    estimate = _estimate(filtered, protocol, derived, ident, extra(probe))
    if probe is None and ident is not None and ident.given:
        probe = reflex_probe(trial, filtered, protocol, ident, estimate.fit.noise)
        if probe is not None:           # the same noise levels: the same course, with the probe's sensitivity
            estimate = _estimate(filtered, protocol, derived, ident, extra(probe), noise=estimate.fit.noise)
    return estimate, probe


def _reflex_shift(probe: ShapeProfile | None, estimate: estimators.Estimate, ident: Identification | None,
                  observable: np.ndarray, level: float) -> ReflexShift | None:
    """What the probed reflex would change, on the one-body course and its band (a coupling's
    limb correction is not in the sensitivity)."""
    if probe is None or estimate.sensitivity is None or len(estimate.sensitivity) < 3:
        return None
    half = np.maximum(estimate.variance_with(ident.coefficient_covariance), 0.0)
    np.sqrt(half, out=half)
    half *= float(stats.norm.ppf(0.5 + level / 2))
    rows = estimate.sensitivity
    return reflex_shift(probe, sensitivity=(rows[0], rows[1], rows[-1]),
                        intervals=None if ident.given else (ident.inertia, ident.damping),
                        stiffness=estimate.stiffness, half_width=half, informed=observable)


def _filtered_and_coupling(trial: Trial, protocol: Protocol, prepared: scheduled.ScheduleInput | None = None):
    """The trial filtered for the model, the corner scan, and the coupling found (the corner
    lowered to :data:`COUPLING_CORNER` of its resonance when the scan chose it); for a curve
    analysis the motion frequency is the perturbation's (:func:`scheduled.perturbation_frequency`)."""
    filtered, scan = filter_for_model(trial, protocol)
    coupling = _coupling(trial, filtered)
    if scan is not None and coupling is not None and coupling.found:
        corner = COUPLING_CORNER * coupling.resonance_hz
        if filtered.cutoff_hz is None or filtered.cutoff_hz > corner:
            filtered = filter_trial(trial, protocol, corner_hz=corner)
    if prepared is not None:
        filtered = dataclasses.replace(filtered, motion_hz=scheduled.perturbation_frequency(
            filtered.angle, prepared, fs=filtered.fs))
    return filtered, scan, coupling


def _model(trial: Trial, filtered: Filtered, protocol: Protocol, derived: DerivedSettings,
           prepared: scheduled.ScheduleInput | None, *, seed: int, where: str):
    """The model's terms (effects, a curve's weights), m and b, and the estimate: the signals with
    the terms' torques taken off, the curve's resolution and torques, the identification, the
    estimate (the curve added back) and the reflex probe."""
    terms = terms_for(trial, filtered, protocol, where=where)
    curve_terms = None if prepared is None else scheduled.curve_terms(filtered, prepared, protocol, terms, where=where)
    ident = _mechanics(filtered, protocol, seed=seed, where=where, effects=terms,
                       basis=None if curve_terms is None else curve_terms.terms,
                       fit=None if curve_terms is None else curve_terms.fit)
    model_terms = joined(terms, None if curve_terms is None else curve_terms.terms)
    if model_terms is not None:
        filtered = filtered_without(filtered, model_terms, ident.coefficients[2:])
    estimate, probe = _estimate_and_probe(trial, filtered, protocol, derived, ident, model_terms)
    if curve_terms is not None:
        first = 2 + len(terms or ())
        estimate = scheduled.with_curve(estimate, curve_terms, ident.coefficients[first:], first_row=first)
    return filtered, curve_terms, ident, estimate, probe


def _coupling(trial: Trial, filtered: Filtered) -> CouplingFit | None:
    """A compliant coupling between limb and device, from the recorded dynamic stiffness
    (external variant: the device's torque against its angle)."""
    if filtered.variant != "external":
        return None
    return detect_coupling(trial.angle, trial.torque, trial.fs, motion_hz=filtered.motion_hz,
                           signal_edge_hz=filtered.bandwidth.signal_edge_hz)


def figure_samples_of(filtered: Filtered, observable: np.ndarray) -> FigureSamples:
    """The samples of a trial's figures: the Kalman model's steps (whichever estimator ran), thinned."""
    decimation = kalman_decimation(filtered.sample_period, filtered.cutoff_hz)
    steps = step_index(len(filtered.angle), edge=filtered.edge, decimation=decimation)
    return figure_samples(steps, filtered.torque, observable, step=filtered.sample_period * decimation,
                          motion_frequency=filtered.motion_hz)


def trial_level_figures(filtered: Filtered, estimate: estimators.Estimate, ident: Identification | None,
                        observable: np.ndarray, *, limb, level: float, seed: int,
                        angle: AngleTerms | None = None) -> TrialLevel:
    """The trial-level figures over joint draws of the course at the Kalman model's steps.

    The draws are the course's posterior (:func:`course_deviations`) plus posterior draws of m and
    b through the estimate's sensitivity, on the informed steps. With ``angle`` the course is the
    stiffness with its change with the angle within the cycle: the part the smoothed course misses
    (:meth:`AngleTerms.missed_course`) added, its coefficients drawn from their sandwich covariance.

    Parameters
    ----------
    filtered : Filtered
        The trial's filtered signals.
    estimate : estimators.Estimate
        The estimator's output; its steps and sensitivity, when it has them, give the draws.
    ident : Identification or None
        Identified inertia and damping with their posterior; None when both were given.
    observable : ndarray of bool, shape (n,)
        The samples informed by motion.
    limb : callable
        Maps a one-body stiffness (an array of any shape) to the limb's, N·m/rad (N/m).
    level : float
        Level of the intervals (0.9 for 90 %).
    seed : int
        Seed of the draws.
    angle : AngleTerms, optional
        The stiffness's change with the angle within the cycle.

    Returns
    -------
    TrialLevel
        Its intervals are NaN when there is nothing to draw (no joint uncertainty).
    """
    samples, base = figure_course(filtered, estimate, observable, angle=angle)
    rng = np.random.default_rng([seed, 14])
    n_draws = course_draws_for(len(samples.index) if estimate.steps is None else len(estimate.steps.index))
    draws, sources = np.repeat(estimate.stiffness[samples.index][None, :], n_draws, axis=0), []
    if estimate.steps is not None:
        draws += course_deviations(estimate.steps, estimate.fit.noise, draws=n_draws, rng=rng,
                                   columns=samples.columns)
        sources.append("course")
    if angle is not None:
        missed = angle.missed[:, samples.columns]
        draws += rng.multivariate_normal(angle.coefficients, angle.covariance, n_draws) @ missed
        sources.append("angle")
    if ident is not None and ident.posterior is not None and estimate.sensitivity is not None:
        coef = ident.coefficient_draws          # m, b and the amplitudes of the effects in the model
        coef = coef[rng.integers(0, len(coef), n_draws)]
        draws += (coef - ident.coefficients) @ estimate.sensitivity[:coef.shape[1], samples.index]
        sources.append("mechanics")
    if not sources:
        draws = np.full_like(draws, np.nan)           # no joint uncertainty: no interval claimed
    informed = samples.informed
    course = limb(base)
    return dataclasses.replace(trial_level(course[informed], limb(draws)[:, informed], samples.torque[informed],
                                           level=level, sources=tuple(sources)),
                               course=course, index=samples.index, informed=informed)


def figure_course(filtered: Filtered, estimate: estimators.Estimate, observable: np.ndarray, *,
                  angle: AngleTerms | None = None) -> tuple[FigureSamples, np.ndarray]:
    """The one-body course the trial-level figures are taken over: the estimate at the figure's
    samples (:func:`figure_samples_of`), with the stiffness's change with the angle within the cycle
    that the smoothed course misses (:meth:`AngleTerms.missed_course`) when ``angle`` is given.
    The analysis's median stiffness is the median of its limb's value over the informed samples;
    the diagnosis's stiffness with an effect removed is taken the same way.

    Returns
    -------
    samples : FigureSamples
    course : ndarray, shape (c,), N·m/rad (N/m)
    """
    samples = figure_samples_of(filtered, observable)
    base = estimate.stiffness[samples.index]
    if angle is not None:
        base = base + angle.coefficients @ angle.missed[:, samples.columns]
    return samples, base


def limb_stiffness(coupling: CouplingFit | None, stiffness, lo, hi):
    """The limb's stiffness and band when a coupling was found.

    With a coupling the one-body estimate is that of the springs in series
    (:meth:`CouplingFit.limb_stiffness` undoes it); unchanged without one, when the correction at
    the median stiffness exceeds :data:`MAX_CORRECTION`, or when the estimate reaches k_c somewhere.

    Parameters
    ----------
    coupling : CouplingFit or None
        The coupling found in the trial, if any.
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        The one-body stiffness and its band.

    Returns
    -------
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        The limb's, or the arguments themselves when unchanged; ``hi`` is inf where the limb's is
        unbounded.
    """
    if coupling is None or not coupling.found:
        return stiffness, lo, hi
    if not coupling.correction(float(np.median(stiffness))) <= MAX_CORRECTION:
        return stiffness, lo, hi
    limb = [coupling.limb_stiffness(x) for x in (stiffness, lo, hi)]
    if not np.all(np.isfinite(limb[0])):
        return stiffness, lo, hi
    return limb[0], limb[1], np.where(np.isfinite(limb[2]), limb[2], np.inf)


def _corner_text(corner_hz: float | None) -> str:
    return "no filter" if corner_hz is None else f"{corner_hz:.3g} Hz"


def _observable(filtered: Filtered, derived: DerivedSettings, bridged: np.ndarray | None = None) -> np.ndarray:
    observable = observer.informed(filtered.velocity, observer_gain=derived.observer_gain,
                                   sample_period=filtered.sample_period, window=derived.observable_window_s,
                                   velocity_threshold=derived.velocity_threshold)
    edge = filtered.edge
    observable[:edge] = observable[len(observable) - edge:] = False     # derivatives unreliable there
    if bridged is not None and len(bridged) == len(observable):
        observable &= ~bridged           # interpolated across a gap in the file: not data
    return observable


def _warnings(trial: Trial, ident: Identification | None, observable: np.ndarray,
              scan: bandwidth.CornerScan | None) -> tuple[str, ...]:
    warnings = list(trial.warnings)
    if scan is not None and scan.gain > CORNER_GAIN_WARNING:
        chosen, spectral = (_corner_text(c) for c in (scan.chosen_hz, scan.spectral_hz))
        warnings.append(f"above {chosen} the torque holds what the model cannot explain (a resonance or coupling of "
                        f"the set-up?): filtered at {chosen} instead of {spectral}, the model predicts "
                        f"{100 * scan.gain:.0f} % more of the torque")
    if ident is not None:
        warnings += list(ident.warnings)
        if ident.inertia_in_expected_range is False:
            lo, hi = ident.expected_inertia
            warnings.append(f"identified inertia {ident.inertia.median:.4g} is outside the range expected for "
                            f"this set-up ({lo:g}–{hi:g})")
    if observable.mean() < 0.5:
        warnings.append(f"only {100 * observable.mean():.0f} % of the trial is informed by motion")
    return tuple(warnings)


def trial_and_protocol(trial: Trial | str | os.PathLike,
                       protocol: Protocol | str | os.PathLike | None) -> tuple[Trial, Protocol]:
    """The trial and protocol :func:`analyze` is given, files read: the protocol's TOML file first,
    then the trial's file with it (:func:`limbstiff.files.read_trial`)."""
    if isinstance(protocol, (str, os.PathLike)):
        protocol = load_protocol(protocol)
    protocol = protocol or Protocol()
    return (read_trial(trial, protocol) if isinstance(trial, (str, os.PathLike)) else trial), protocol


@one_blas_thread
def analyze(trial: Trial | str | os.PathLike, protocol: Protocol | str | os.PathLike | None = None, *,
            inertia: float | None = None, damping: float | None = None, observer_gain: float | None = None,
            estimator: str | None = None, seed: int = 0,
            reference: np.ndarray | None = None, effects: Sequence[str] | None = None) -> StiffnessResult:
    """Estimate the stiffness course of one trial.

    Parameters
    ----------
    trial : Trial, str or path-like
        The trial, or its file (read by :func:`limbstiff.files.read_trial` with the protocol).
    protocol : Protocol, str or path-like, optional
        Settings of the set-up, or its TOML file; defaults derive everything from the data.
    inertia : float, optional, kg·m² (kg)
        Fixes m (overrides the protocol).
    damping : float, optional, N·m·s/rad (N·s/m)
        Fixes b (overrides the protocol).
    observer_gain : float, optional, 1/rad (1/m)
        Fixes α (overrides the protocol).
    estimator : str, optional
        Estimator name (overrides the protocol).
    seed : int
        Seed of every random draw (recorded in the result).
    reference : ndarray, shape (n,), optional, N·m/rad (N/m)
        Reference stiffness (for example from ``limbstiff calibrate``); defaults to the
        trial's ``stiffness_true``.
    effects : sequence of str, optional
        Unmodelled effects to put in the model (overrides the protocol's ``effects``; names of
        :data:`limbstiff.protocol.MODEL_EFFECTS`, e.g. ``("reflex",)``): their shapes chosen from
        the data, their amplitudes identified with m and b and carried into the band
        (:mod:`limbstiff.effects.in_model`). External variant and Kalman estimator only.

    Returns
    -------
    StiffnessResult

    Raises
    ------
    TrialError
        When the trial cannot give a stiffness (no motion, missing channel…).
    """
    trial, protocol = trial_and_protocol(trial, protocol)
    protocol = protocol.override(inertia=inertia, damping=damping, observer_gain=observer_gain, estimator=estimator,
                                 effects=None if effects is None else
                                 ((effects,) if isinstance(effects, str) else tuple(effects)))
    where = _where(trial)
    found = plausible(trial, protocol)
    prepared = scheduled.schedule_input(trial, protocol, where=where)
    trial = trial if prepared is None else prepared.trial
    filtered, scan, coupling = _filtered_and_coupling(trial, protocol, prepared)
    derived = derive_settings(filtered, protocol, where=where)
    filtered, curve_terms, ident, estimate, probe = _model(trial, filtered, protocol, derived, prepared, seed=seed,
                                                           where=where)
    observable = _observable(filtered, derived, trial.bridged)
    if not np.all(np.isfinite(estimate.stiffness)):
        raise TrialError(where, f"the {protocol.discretisation} observer diverged with gain "
                                f"{derived.observer_gain:.3g} (use the exact discretisation or a lower gain)")
    if estimate.steps is not None:                # a posterior variance (the observers' is a spread of ratios)
        observable = band_informed(estimate.variance, observable)
    stiffness, lo, hi = _band(estimate, ident, coupling, observable, protocol.ci_level)
    corrected = stiffness is not estimate.stiffness
    angle = (None if estimate.steps is None else
             angle_terms_on(estimate.steps, estimate.fit.noise, motion_frequency=filtered.motion_hz))
    figures = trial_level_figures(filtered, estimate, ident, observable, level=protocol.ci_level, seed=seed,
                                  limb=coupling.limb_stiffness if corrected else (lambda x: x), angle=angle)
    checks = check_analysis(filtered, stiffness=stiffness, lo=lo, hi=hi, observable=observable, ident=ident,
                            noise=_check_noise(filtered, estimate, ident), coupling=coupling,
                            corrected=corrected, angle_terms=angle)
    reflex = reflex_check(_reflex_shift(probe, estimate, ident, observable, protocol.ci_level))
    curve = curve_terms and scheduled.curve_analysis(prepared, curve_terms, estimate, ident, observable=observable,
                                                     stiffness=stiffness, level=protocol.ci_level, seed=seed)
    more = ((reflex,) if reflex is not None else ()) + (curve.checks if curve else ())
    checks = units_checks(ModelChecks(checks.checks + more), implausible_inertia(trial, protocol, ident, found))
    return StiffnessResult(
        trial=trial, variant=filtered.variant, estimator=protocol.estimator, stiffness=stiffness,
        stiffness_lo=lo, stiffness_hi=hi, observable=observable,
        inertia=None if ident is None else ident.inertia, damping=None if ident is None else ident.damping,
        ci_level=protocol.ci_level, seed=seed, protocol=protocol, filtered=filtered, derived=derived,
        fit=estimate.fit, identification=ident, checks=checks, warnings=_warnings(trial, ident, observable, scan),
        corner_scan=scan, coupling=coupling, trial_level=figures,
        reference=trial.stiffness_true if reference is None else reference, curve=curve)
