"""Stiffness analysis of one trial, as a straight pipeline.

:func:`analyze` is the library call behind ``limbstiff analyze``. It resolves the settings
(protocol, then explicit arguments) and runs, each step once and none undoing an earlier one:
read → filter (the corner and the coupling decided once, :mod:`limbstiff.filtering`) → the
settings the protocol leaves open (:mod:`limbstiff.settings`) → the model's terms
(:mod:`limbstiff.specification`) → m, b and the terms' coefficients identified, read by name
(:class:`~limbstiff.coefficients.Coefficients`) → the noise levels fitted once and the course
estimated → the band (:mod:`limbstiff.band`), the figures (:mod:`limbstiff.figure_draws`) and the
checks → a :class:`~limbstiff.result.StiffnessResult`. No file is written here; a trial or protocol
given as a path is read through :mod:`limbstiff.files`.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from . import bandwidth
from .band import ModelForm, half_width, model_form_share, stiffness_band
from .blas_threads import one_blas_thread
from .checks import check_analysis
from .checks.analysis import sign_hint
from .checks.analysis import median_sign
from .checks.model import angle_terms_on
from .checks.reflex import ReflexShift, reflex_check
from .checks.shape import velocity_shape_check
from .checks.units import implausible_inertia, plausible, units_checks
from .checks.verdict import MOTION_MIN, ModelChecks
from .coefficients import Coefficients
from .curve_result import curve_analysis
from .effects.in_model import (ShapeProfile, probe_delta, reflex_probe, reflex_shift, rival_columns,
                               velocity_shape_miss)
from .effects.model_form import effects_form, model_form
from .errors import TrialError
from .estimate import estimators
from .estimate.informed import band_informed
from .estimate.observer import informed_samples
from .figure_draws import trial_level_figures
from .files import read_trial
from .filtered import Filtered
from .filtering import ModelSignals, filter_for_model, filtered_for_analysis
from .mechanics.identification import Identification, identify_mechanics
from .protocol import Protocol, load_protocol
from .result import StiffnessResult, result_units, software
from .scheduled import run as scheduled
from .settings import DerivedSettings, derive_settings, informed_by_motion
from .specification import ModelSpecification, model_specification, spring_signals, stiffness_course
from .statespace.noise import NoiseLevels
from .trial import Trial

#: A lower corner that predicts this much more of the torque (share of its variance) than the
#: spectral one is said in the warnings: the torque above it holds what the model cannot explain.
CORNER_GAIN_WARNING = 0.05


def _where(trial: Trial) -> str:
    return trial.source or trial.name


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


def _mechanics(filtered: Filtered, protocol: Protocol, spec: ModelSpecification, *, seed: int,
               where: str) -> Identification | None:
    """m, b and the coefficients of the model's terms, identified together (external variant; with
    the check of the protocol's expected range)."""
    if filtered.variant != "external":
        return None
    try:
        ident = identify_mechanics(filtered, protocol, rng=np.random.default_rng(seed), seed=seed, where=where,
                                   effects=spec.effects, basis=spec.curve_terms,
                                   fit=None if spec.curve is None else spec.curve.fit)
    except TrialError as exc:
        hint = sign_hint(filtered, scale=_torque_scale(protocol, filtered.variant))
        # the sign is the cause to fix: the symptom, then the sign's advice alone (not the inertia's)
        raise (TrialError(exc.source, f"{exc.problem.split(';')[0]}: {hint}") if hint else exc) from None
    return dataclasses.replace(ident, expected_inertia=protocol.inertia_range)


def _torque_scale(protocol: Protocol, variant: str) -> float:
    """The protocol's ``scale`` for the analysed torque's column (1 when it sets none)."""
    column = protocol.columns.get("torque" if variant == "external" else "elastic_torque")
    return 1.0 if column is None else float(column.scale)


@dataclass(frozen=True)
class Course:
    """The estimation step's outcome.

    Parameters
    ----------
    filtered : Filtered
        The signals the spring is left to explain (:func:`spring_signals`).
    coefficients : Coefficients or None
        m, b and the terms' coefficients by name (None for the direct variant).
    noise : NoiseLevels
        The Kalman model's noise levels, fitted once: the estimator's, the probe's and the checks'.
    estimate : estimators.Estimate
        The stiffness course (the curve plus the walk) with its sensitivity to each coefficient.
    probe : ShapeProfile or None
        The reflex the ``reflex`` check probes for.
    """

    filtered: Filtered
    coefficients: Coefficients | None
    noise: NoiseLevels
    estimate: estimators.Estimate
    probe: ShapeProfile | None

    @property
    def covariance(self) -> np.ndarray | None:
        """The coefficients' joint covariance, shape (p, p) (None for the direct variant)."""
        return None if self.coefficients is None else self.coefficients.covariance


def _estimate(trial: Trial, filtered: Filtered, protocol: Protocol, derived: DerivedSettings,
              spec: ModelSpecification, ident: Identification | None) -> Course:
    """The course on the signals the spring is left to explain, at the Kalman model's noise levels
    (the identification's, or fitted here once), with its sensitivity to the model's terms and,
    last, to the reflex the ``reflex`` check probes for (:func:`reflex_probe`)."""
    coef = None if ident is None else Coefficients.of(ident)
    filtered = spring_signals(filtered, spec, coef)
    mech = {} if ident is None else {"inertia": ident.inertia.median, "damping": ident.damping.median}
    noise = (ident.noise_levels if ident is not None and ident.noise_levels is not None
             else estimators.kalman_noise(filtered, **mech))
    probe = reflex_probe(trial, filtered, protocol, ident, noise)
    if protocol.estimator == "kalman":
        rows = ([spec.terms.columns] if spec.terms is not None else []) + ([probe.column[None]] if probe else [])
        walk = estimators.kalman(filtered, noise=noise, extra_regressors=np.vstack(rows) if rows else None, **mech)
    else:
        walk = estimators.observers(filtered, smoothed=protocol.estimator == "observer-smoothed",
                                    gain=derived.observer_gain, velocity_threshold=derived.velocity_threshold,
                                    discretisation=protocol.discretisation, **mech)
    return Course(filtered, coef, noise, stiffness_course(walk, spec, coef), probe)


def _reflex_shift(course: Course, ident: Identification | None, observable: np.ndarray,
                  level: float) -> ReflexShift | None:
    """What the probed reflex would change, on the one-body course and its band (a coupling's
    limb correction is not in the sensitivity)."""
    estimate, coef = course.estimate, course.coefficients
    if course.probe is None or estimate.sensitivity is None or len(estimate.sensitivity) < 3:
        return None
    rows = estimate.sensitivity
    m, b = coef.positions(("inertia", "damping"))
    return reflex_shift(course.probe, sensitivity=(rows[m], rows[b], rows[len(coef.names)]),
                        intervals=None if ident.given else (ident.inertia, ident.damping),
                        stiffness=estimate.stiffness, half_width=half_width(estimate, course.covariance, level),
                        informed=observable)


def _model_form(spec: ModelSpecification, course: Course, ident: Identification | None) -> ModelForm | None:
    """The alternatives to the chosen model of comparable evidence (:mod:`limbstiff.effects.model_form`):
    the effects' other shapes and each effect left out, or the probed reflex put in; None without
    the Kalman estimator's steps and sensitivity."""
    estimate, coef = course.estimate, course.coefficients
    if estimate.steps is None or estimate.sensitivity is None or coef is None:
        return None
    logs, changes = [], []
    if spec.effects is not None:
        at = coef.positions(spec.effects.names)
        logs, changes = effects_form(spec.effects, coef.values[at], estimate.sensitivity[at], steps=estimate.steps,
                                     noise=estimate.fit.noise)
    probe = course.probe
    if probe is not None and len(estimate.sensitivity) > len(coef.names):
        rows = estimate.sensitivity[[*coef.positions(("inertia", "damping")), len(coef.names)]]
        logs.append(probe.loglik_gain - float(np.log(max(probe.shapes_tried, 1))))
        changes.append(probe_delta(probe, None if ident.given else (ident.inertia, ident.damping)) @ rows)
    return model_form(logs, changes)


def _informed(course: Course, derived: DerivedSettings, trial: Trial, protocol: Protocol) -> np.ndarray:
    """The samples the motion informs, and (a posterior variance: the observers' is a spread of
    ratios) where the course's band is informative."""
    observable = informed_by_motion(course.filtered, derived, trial.bridged)
    if not np.all(np.isfinite(course.estimate.stiffness)):
        raise TrialError(_where(trial), f"the {protocol.discretisation} observer diverged with gain "
                                        f"{derived.observer_gain:.3g} (use the exact discretisation or a lower gain)")
    if course.estimate.steps is not None:
        observable = band_informed(course.estimate.variance, observable)
    return observable


def _result(trial: Trial, protocol: Protocol, signals: ModelSignals, derived: DerivedSettings,
            ident: Identification | None, course: Course, *, spec: ModelSpecification, prepared, found,
            seed: int, reference: np.ndarray | None) -> StiffnessResult:
    """The band, the figures and the checks of the course, as the result."""
    estimate, level, coupling = course.estimate, protocol.ci_level, signals.coupling
    observable = _informed(course, derived, trial, protocol)
    form = _model_form(spec, course, ident)
    stiffness, lo, hi = stiffness_band(estimate, course.covariance, coupling, observable, level, form)
    corrected = stiffness is not estimate.stiffness
    miss = None if estimate.steps is None else velocity_shape_miss(
        trial, signals.filtered, estimate.steps, estimate.fit.noise, observable=observable,
        identified=ident is not None and not ident.given)
    angle = (None if estimate.steps is None else
             angle_terms_on(estimate.steps, estimate.fit.noise, motion_frequency=course.filtered.motion_hz,
                            beside=rival_columns(miss)))
    figures = trial_level_figures(course.filtered, estimate, course.coefficients, observable, level=level,
                                  seed=seed, limb=coupling.limb_stiffness if corrected else (lambda x: x), angle=angle,
                                  form=form)
    informed = informed_samples(observable)
    checks = check_analysis(course.filtered, stiffness=stiffness, lo=lo, hi=hi, observable=observable, ident=ident,
                            noise=course.noise, coupling=coupling, corrected=corrected, angle_terms=angle,
                            torque_scale=_torque_scale(protocol, course.filtered.variant),
                            form_share=model_form_share(estimate, course.covariance, form, informed))
    reflex = reflex_check(_reflex_shift(course, ident, observable, level))
    curve = spec.curve and curve_analysis(prepared, spec.curve, estimate, ident, filtered=signals.filtered,
                                          observable=observable, stiffness=stiffness, level=level, seed=seed)
    shape = velocity_shape_check(miss, stiffness=float(np.median(stiffness[informed])),
                                 half_width=float(np.median((hi - lo)[informed])) / 2, level=level,
                                 coupled=coupling is not None and coupling.found)
    more = tuple(c for c in (reflex, shape, median_sign(figures.median_stiffness)) if c is not None)
    more += curve.checks if curve else ()
    checks = units_checks(ModelChecks(checks.checks + more), implausible_inertia(trial, protocol, ident, found))
    curve = curve and dataclasses.replace(curve, trial_checks=checks)
    return StiffnessResult(
        trial=trial, variant=signals.filtered.variant, estimator=protocol.estimator, stiffness=stiffness,
        stiffness_lo=lo, stiffness_hi=hi, observable=observable,
        inertia=None if ident is None else ident.inertia, damping=None if ident is None else ident.damping,
        ci_level=level, seed=seed, protocol=protocol, filtered=course.filtered, derived=derived,
        fit=estimate.fit, identification=ident, checks=checks,
        warnings=_warnings(trial, ident, observable, signals.scan), corner_scan=signals.scan, coupling=coupling,
        trial_level=figures, reference=trial.stiffness_true if reference is None else reference,
        curve=curve)


def _corner_text(corner_hz: float | None) -> str:
    return "no filter" if corner_hz is None else f"{corner_hz:.3g} Hz"


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
    if observable.mean() < MOTION_MIN:
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
    signals = filtered_for_analysis(trial, protocol, prepared)
    derived = derive_settings(signals.filtered, protocol, where=where)
    spec = model_specification(trial, signals.filtered, protocol, prepared, where=where)
    ident = _mechanics(signals.filtered, protocol, spec, seed=seed, where=where)
    course = _estimate(trial, signals.filtered, protocol, derived, spec, ident)
    return _result(trial, protocol, signals, derived, ident, course, spec=spec, prepared=prepared, found=found,
                   seed=seed, reference=reference)
