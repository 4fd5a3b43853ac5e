"""Stiffness analysis of one trial: signals → (inertia, damping) → observer → result.

:func:`analyze` is the library call behind ``limbstiff analyze``. It resolves the settings
(protocol, then explicit arguments), derives what the protocol leaves open from the trial's
own data (filter bandwidth, observer gain, velocity threshold, observability window, and —
for the external-torque variant — inertia and damping), runs the estimator and returns a
:class:`~limbstiff.result.StiffnessResult`. No file I/O here.
"""

from __future__ import annotations

import numpy as np

from scipy import stats

from . import estimators, identify, observer, posterior, signals, smoothing
from .errors import TrialError
from .protocol import Protocol
from .result import Interval, StiffnessResult, software
from .trial import Trial

#: Default memory of the observer, as a fraction of the range of motion: by (8) the estimate
#: forgets its past as exp(−α·path), so 1/α is the path over which it averages the local slope.
MEMORY_FRACTION_OF_RANGE = 1 / 20
#: Speeds below this multiple of the velocity noise level count as no motion.
VELOCITY_NOISE_MULTIPLE = 3.0
#: Observability window, in periods of the typical motion frequency.
OBSERVABLE_PERIODS = 2.0
#: Identification windows, in periods of the typical motion frequency.
IDENTIFY_PERIODS = 4.0


def derivatives(trial: Trial, protocol: Protocol, order: int = 3):
    """Filtered signals and their derivatives, the same chain for every channel.

    Parameters
    ----------
    trial : Trial
    protocol : Protocol
    order : int
        Highest derivative of the angle wanted (3 for the external variant).

    Returns
    -------
    angle : ndarray, shape (order + 1, n)
        y, ẏ, ÿ, y⃛ (rad, rad/s, rad/s², rad/s³).
    torques : dict of str to ndarray, shape (2, n)
        For ``torque`` and ``elastic_torque`` (those recorded): f and ḟ.
    bandwidth : signals.Bandwidth
    """
    fs = trial.fs
    channels = {"torque": trial.torque, "elastic_torque": trial.elastic_torque}
    recorded = trial.torque if trial.torque is not None else trial.elastic_torque
    bandwidth = signals.choose_bandwidth(trial.angle, fs, torque=recorded)
    if protocol.derivatives == "paper":
        kw = dict(prefilter_time_constant=protocol.prefilter_time_constant,
                  dirty_derivative_time_constant=protocol.dirty_derivative_time_constant)
        angle = signals.paper_derivatives(trial.angle, fs, order, **kw)
        torques = {k: signals.paper_derivatives(v, fs, 1, **kw) for k, v in channels.items() if v is not None}
        cutoff = None
    else:
        cutoff = protocol.bandwidth_hz if protocol.bandwidth_hz is not None else bandwidth.cutoff_hz
        if cutoff is not None and cutoff >= signals.MAX_BANDWIDTH_FRACTION * fs:
            cutoff = None

        def chain(x, n):
            return signals.central_derivatives(signals.zero_phase_lowpass(x, fs, cutoff), fs, n)

        angle = chain(trial.angle, order)
        torques = {k: chain(v, 1) for k, v in channels.items() if v is not None}
    used = signals.Bandwidth(cutoff_hz=cutoff, signal_edge_hz=bandwidth.signal_edge_hz,
                             noise_floor=bandwidth.noise_floor,
                             quantisation_step=bandwidth.quantisation_step)
    return angle, torques, used


def range_of_motion(angle: np.ndarray) -> float:
    """Span of the central 95 % of the angle, rad (m): robust to spikes and drift ends."""
    return float(np.subtract(*np.percentile(angle, [97.5, 2.5])))


def default_gain(angle: np.ndarray) -> float:
    """Observer gain α from the data: memory 1/α of :data:`MEMORY_FRACTION_OF_RANGE` of the range, 1/rad (1/m)."""
    return 1.0 / (MEMORY_FRACTION_OF_RANGE * range_of_motion(angle))


def _variant(trial: Trial, protocol: Protocol) -> str:
    where = trial.source or trial.name
    variant = trial.variant if protocol.variant == "auto" else protocol.variant
    if variant == "direct" and trial.elastic_torque is None:
        raise TrialError(where, "the direct variant needs an elastic torque/force column")
    if variant == "external" and trial.torque is None:
        raise TrialError(where, "the external variant needs an external torque/force column")
    return variant


def _prepare(trial: Trial, protocol: Protocol):
    """What both :func:`analyze` and :func:`identify_trial` start from.

    Returns
    -------
    variant : str
    angle, torques, bandwidth : see :func:`derivatives`
    sig : estimators.Signals
        The angle and the torque of the variant (external or elastic), filtered alike.
    motion : float, Hz
        Typical motion frequency.
    """
    variant = _variant(trial, protocol)
    angle, torques, bandwidth = derivatives(trial, protocol)
    torque = torques["torque"] if variant == "external" else torques["elastic_torque"]
    sig = estimators.Signals(angle, torque, trial.sample_period, bandwidth.cutoff_hz)
    return variant, angle, torques, bandwidth, sig, signals.motion_frequency(angle[0], trial.fs)


def _mechanics(trial, protocol, sig, motion, ci_level, rng, seed):
    """Inertia and damping: given, or identified (least squares, ML, then the emcee posterior).

    Returns
    -------
    inertia, damping : Interval
    covariance : ndarray, shape (2, 2)
        Posterior covariance of (m, b) (from the draws); zero where a value is given.
    details : dict
    posterior : posterior.Posterior or None
    """
    where = trial.source or trial.name
    m, b = protocol.inertia, protocol.damping
    if m is not None and b is not None:
        return Interval.fixed(m), Interval.fixed(b), np.zeros((2, 2)), {"method": "given"}, None
    y, f = sig.angle, sig.torque[0]
    guess = identify.least_squares(f, y[0], y[1], y[2], sample_period=trial.sample_period,
                                   window=IDENTIFY_PERIODS / motion)
    decimation = estimators.kalman_decimation(sig)
    edge = signals.edge_samples(trial.fs, sig.cutoff_hz)
    problem = identify.MechanicsProblem.build(y[0], y[1], y[2], f, sample_period=trial.sample_period,
                                              decimation=decimation, motion_frequency=motion, guess=guess,
                                              edge=edge)
    fit = identify.kalman_mechanics(problem, guess=guess)
    post = posterior.sample(problem, start=fit, inertia_prior=protocol.inertia_prior,
                            damping_prior=protocol.damping_prior, rng=rng, seed=seed)
    draws = post.mechanics.copy()
    details = {"method": "kalman+emcee",
               "least_squares": {"inertia": guess.inertia, "damping": guess.damping,
                                 "window_s": guess.window, "condition": guess.condition},
               "maximum_likelihood": {"inertia": fit.inertia, "damping": fit.damping,
                                      "noise_levels": fit.noise.to_dict(), "loglik": fit.loglik},
               "noise_levels": post.noise_levels().to_dict(), "decimation": decimation,
               "mcmc": post.diagnostics.to_dict(), "warnings": list(post.warnings)}
    out = []
    for j, (name, given) in enumerate((("inertia", m), ("damping", b))):
        if given is not None:
            draws[:, j] = given
            out.append(Interval.fixed(given))
            continue
        lo, med, hi = np.quantile(draws[:, j], [0.5 - ci_level / 2, 0.5, 0.5 + ci_level / 2])
        if not med > 0:
            raise TrialError(where, f"{name} could not be identified (its posterior median is "
                                    f"{med:.3g}); give it with --{name} or in the protocol")
        out.append(Interval(float(med), float(lo), float(hi)))
    return out[0], out[1], np.cov(draws.T), details, post


def identify_trial(trial: Trial, protocol: Protocol | None = None, *, seed: int = 0) -> dict:
    """Identify inertia and damping of one trial only (``limbstiff identify``).

    Returns
    -------
    dict
        ``summary`` (JSON-ready: trial, intervals, noise levels, MCMC diagnostics) and
        ``posterior`` (:class:`~limbstiff.posterior.Posterior`, None when both are given).
    """
    protocol = protocol or Protocol()
    variant, _, _, _, sig, motion = _prepare(trial, protocol)
    if variant != "external":
        raise TrialError(trial.source or trial.name, "inertia and damping are identified from the external "
                                                     "torque; this trial has only the elastic torque (direct variant)")
    m, b, cov, ident, post = _mechanics(trial, protocol, sig, motion, protocol.ci_level,
                                        np.random.default_rng(seed), seed)
    summary = {"trial": trial.name, "source": trial.source, "source_sha256": trial.source_sha256,
               "ci_level": protocol.ci_level, "inertia": m.to_dict(), "damping": b.to_dict(),
               "covariance": cov.tolist(), "units": {k: trial.units[k] for k in ("inertia", "damping")},
               "identification": ident, "mcmc": ident.get("mcmc"), "seed": seed,
               "warnings": list(trial.warnings) + list(ident.get("warnings", [])),
               "software": software(), "metadata": dict(trial.metadata)}
    return {"summary": summary, "posterior": post}


def analyze(trial: Trial, protocol: Protocol | None = None, *, inertia: float | None = None,
            damping: float | None = None, observer_gain: float | None = None,
            estimator: str | None = None, seed: int = 0,
            reference: np.ndarray | None = None) -> StiffnessResult:
    """Estimate the stiffness course of one trial.

    Parameters
    ----------
    trial : Trial
    protocol : Protocol, optional
        Settings of the set-up; defaults derive everything from the data.
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

    Returns
    -------
    StiffnessResult

    Raises
    ------
    TrialError
        When the trial cannot give a stiffness (no motion, missing channel…).
    """
    protocol = (protocol or Protocol()).override(inertia=inertia, damping=damping,
                                                 observer_gain=observer_gain, estimator=estimator)
    where = trial.source or trial.name
    warnings = list(trial.warnings)
    variant, angle, torques, bandwidth, sig, motion = _prepare(trial, protocol)
    ts, fs = trial.sample_period, trial.fs
    range_ = range_of_motion(angle[0])
    if not range_ > 0:
        raise TrialError(where, "no motion: the angle does not change")
    gain = protocol.observer_gain or default_gain(angle[0])
    threshold = VELOCITY_NOISE_MULTIPLE * signals.velocity_noise_level(trial.angle, fs, bandwidth.cutoff_hz)

    m = b = ident = post = None
    cov = None
    mech = {}
    if variant == "external":
        m, b, cov, ident, post = _mechanics(trial, protocol, sig, motion, protocol.ci_level,
                                            np.random.default_rng(seed), seed)
        mech = {"inertia": m.median, "damping": b.median}
        if post is not None:
            warnings += list(post.warnings)
        if protocol.inertia_range is not None:
            lo, hi = protocol.inertia_range
            inside = lo <= m.median <= hi
            ident["inertia_in_expected_range"] = {"range": [lo, hi], "inside": inside}
            if not inside:
                warnings.append(f"identified inertia {m.median:.4g} is outside the range expected for "
                                f"this set-up ({lo:g}–{hi:g})")
    if protocol.estimator == "kalman":
        # the noise levels fitted with m and b (one likelihood for both), when they were fitted
        noise = smoothing.NoiseLevels(**ident["noise_levels"]) if ident and "noise_levels" in ident else None
        estimate = estimators.kalman(sig, motion_frequency=motion, noise=noise, **mech)
    else:
        estimate = estimators.observers(sig, smoothed=protocol.estimator == "observer-smoothed", gain=gain,
                                        velocity_threshold=threshold, discretisation=protocol.discretisation,
                                        **mech)
    stiffness = estimate.stiffness
    observable = observer.informed(angle[1], observer_gain=gain, sample_period=ts,
                                   window=OBSERVABLE_PERIODS / motion, velocity_threshold=threshold)
    edge = signals.edge_samples(fs, bandwidth.cutoff_hz)
    observable[:edge] = observable[len(observable) - edge:] = False     # derivatives unreliable there
    if not np.all(np.isfinite(stiffness)):
        raise TrialError(where, f"the {protocol.discretisation} observer diverged with gain {gain:.3g} "
                                "(use the exact discretisation or a lower gain)")
    if observable.mean() < 0.5:
        warnings.append(f"only {100 * observable.mean():.0f} % of the trial is informed by motion")
    z = float(stats.norm.ppf(0.5 + protocol.ci_level / 2))
    half = z * np.sqrt(np.maximum(estimate.variance_with(cov), 0.0))

    if reference is None:
        reference = trial.stiffness_true
    details = {
        "observer_gain": gain,
        "observer_memory": 1.0 / gain,
        "discretisation": protocol.discretisation,
        "derivatives": protocol.derivatives,
        "bandwidth": bandwidth.to_dict(),
        "torque_quantisation_step": signals.quantisation_step(
            trial.torque if trial.torque is not None else trial.elastic_torque),
        "motion_frequency_hz": motion,
        "range_of_motion": range_,
        "velocity_threshold": threshold,
        "observable_window_s": OBSERVABLE_PERIODS / motion,
        "identification": ident,
        "estimator": dict(estimate.details),
    }
    return StiffnessResult(
        trial=trial, variant=variant, estimator=protocol.estimator, stiffness=stiffness,
        stiffness_lo=stiffness - half, stiffness_hi=stiffness + half, observable=observable,
        inertia=m, damping=b, ci_level=protocol.ci_level, seed=seed, settings=protocol.to_dict(),
        details=details, warnings=tuple(warnings), reference=reference, posterior=post)
