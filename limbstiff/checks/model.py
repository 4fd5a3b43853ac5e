"""What the model checks measure, on the analysis's own Kalman model and filtered signals.

* :func:`heldout_explained`: the share of the recorded torque the model predicts on whole motion
  periods it was not given (folds of :mod:`limbstiff.heldout`; their measurements left out of
  the filter and smoother, so the elastic torque there is carried across by ds = σ·dy from both
  sides);
* :func:`innovation_statistics`: the one-step prediction errors, which are white and
  unrelated to the motion when the model is right;
* :func:`elastic_slopes`: the local slope of a torque on the angle, window by window, for the
  sign of the recorded torque;
* :func:`angle_terms`: a stiffness that changes with the angle within each motion cycle,
  which the model's random walk, slow beside the motion, averages over the cycle.

Pure numpy: no I/O.
"""

from __future__ import annotations

import warnings

from dataclasses import dataclass

import numpy as np

from .. import heldout
from ..statespace import kernels
from ..estimate.angle_terms import AngleTerms, fit_angle_terms
from ..statespace.noise import NoiseLevels
from ..statespace.smoother import kalman_smoother
from ..statespace.steps import ModelSteps, kalman_decimation, model_steps
from ..statespace.noise import noise_bounds
from ..filtered import Filtered

#: Held-out blocks are this many periods of the typical motion long: whole periods, so that a
#: block holds the excursions that reveal the stiffness, not a fragment the neighbours explain.
HELDOUT_PERIODS = 2.0
#: Fewest folds (blocks) a held-out score is computed on; a trial with fewer is too short.
MIN_FOLDS = 3
#: Innovation lags (filter steps) of the whiteness statistic.
WHITENESS_LAGS = 10
#: Longest lag of the innovations behind the velocity, s: a stretch reflex answers in 20–80 ms.
VELOCITY_LAG_S = 0.1
#: Fewest model steps a statistic is computed on (below it: not computed, the check passes).
MIN_STEPS = 100


@dataclass(frozen=True)
class InnovationStatistics:
    """How far the one-step prediction errors are from white noise unrelated to the motion.

    Parameters
    ----------
    autocorrelation : float
        Largest |autocorrelation| of the standardised innovations over lags 1–:data:`WHITENESS_LAGS`.
    velocity_correlation : float
        Largest |correlation| of the innovations with the velocity they follow by 0–:data:`VELOCITY_LAG_S`.
    """

    autocorrelation: float
    velocity_correlation: float


def _steps(filtered: Filtered, inertia: float, damping: float) -> ModelSteps:
    return model_steps(filtered.angle, filtered.elastic_torque(inertia, damping), sample_period=filtered.sample_period,
                       decimation=kalman_decimation(filtered.sample_period, filtered.cutoff_hz), edge=filtered.edge,
                       motion_frequency=filtered.motion_hz, scale_from=filtered.torque)


def heldout_explained(filtered: Filtered, *, inertia: float, damping: float, noise: NoiseLevels,
                      reference: np.ndarray | None = None) -> float | None:
    """Share of the torque's variance the model predicts on held-out whole motion periods.

    Blocks of :data:`HELDOUT_PERIODS` motion periods are dealt in turn to :data:`~limbstiff.heldout.FOLDS`
    folds (:mod:`limbstiff.heldout`; no guard: the left-out measurements are not given to the
    filter at all). For each fold the filter and smoother run with that fold's measurements left
    out; across each left-out gap the elastic torque is then carried from the gap's two edges by
    ds = σ·dy, with σ a function of the angle fitted to the training steps beside the gap
    (:func:`_across_gap`). Plus m·ÿ + b·ẏ that is the prediction of the recorded torque.

    Parameters
    ----------
    reference : ndarray, shape (n,), optional
        The torque to predict (default the filtered one); scans over corners give one torque
        for all, so that a lower corner does not win by removing noise from its own target.

    Returns
    -------
    float or None
        1 − mean((f − f̂)²)/var(f) over the model's steps, every one held out once (1: perfect,
        ≤ 0: no better than the mean); None when the trial has fewer than :data:`MIN_FOLDS`
        blocks or :data:`MIN_STEPS` steps.
    """
    st = _steps(filtered, inertia, damping)
    if len(st.index) < MIN_STEPS:
        return None
    block = np.floor(np.arange(len(st.index)) * st.step * filtered.motion_hz / HELDOUT_PERIODS).astype(int)
    n_folds = min(heldout.FOLDS, block[-1] + 1)       # a short trial: each of its blocks left out in turn
    if n_folds < MIN_FOLDS:
        return None
    folds = heldout.folds_of(block, heldout.interleaved(block, n_folds), guard=0)
    i = st.index

    def predict(k: int) -> np.ndarray:
        smoothed = kalman_smoother(st.increments, st.measured, noise, step=st.step, deflection=st.deflection,
                                   initial_mean=st.initial_mean, initial_cov=st.initial_cov, loglik=False,
                                   observed=folds.training[k])
        left_out = folds.held(k)
        elastic = np.empty(len(i))
        for a, b in _runs(left_out):
            elastic[a:b] = _across_gap(st.angle, smoothed.mean, a, b)
        at = i[left_out]
        return elastic[left_out] + inertia * filtered.acceleration[at] + damping * filtered.velocity[at]

    torque = (filtered.torque if reference is None else reference)[i]
    scores = heldout.score(folds, torque, predict)
    return float(1.0 - np.mean(scores.error ** 2) / max(float(np.var(torque)), 1e-300))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def _across_gap(angle: np.ndarray, smoothed: np.ndarray, a: int, b: int) -> np.ndarray:
    """Elastic torque over the left-out steps a…b−1 from the training data on either side.

    σ(y) is a quadratic fitted to the smoothed stiffness of the training steps within one gap
    length before and after (a stiffness that depends on the angle, as a nonlinear spring's
    does, is followed through the motion; one that drifts in time is averaged), held at its
    values at the ends of those steps' angles beyond them (:func:`_clipped_antiderivative`).
    The torque is integrated, ∫σ(y)dy, forwards from the last step before the gap and backwards
    from the first after it, and the two are blended linearly in time (one side only at the
    trial's ends).
    """
    n, length = len(angle), b - a
    near = np.r_[max(0, a - length):a, b:min(n, b + length)]
    y, sigma = angle[near], smoothed[near, 1]
    lo, hi = (float(y.min()), float(y.max())) if len(near) else (0.0, 0.0)
    if hi == lo:
        coef = np.array([float(np.mean(sigma)) if len(near) else 0.0])
    else:
        # an encoder's angle repeats its values: a quadratic needs three distinct ones
        degree = 2 if np.any((y > lo) & (y < hi)) else 1
        with warnings.catch_warnings():
            # a near-degenerate spread of angles: the fit is still the least-squares one, and the
            # user's terminal is not the place for numpy's RankWarning
            warnings.simplefilter("ignore", np.exceptions.RankWarning)
            coef = np.polyfit(y, sigma, degree)
    first, last = max(a - 1, 0), min(b + 1, n)
    elastic = _clipped_antiderivative(coef, lo, hi)(angle[first:last])
    gap = elastic[a - first:a - first + length]
    forward = smoothed[a - 1, 0] + gap - elastic[0] if a > 0 else None
    backward = smoothed[b, 0] - (elastic[-1] - gap) if b < n else None
    if forward is None or backward is None:
        return forward if backward is None else backward
    w = (np.arange(length) + 1.0) / (length + 1.0)
    return (1.0 - w) * forward + w * backward


def _clipped_antiderivative(coef: np.ndarray, lo: float, hi: float):
    """∫σ dy for the polynomial σ(y) (``coef``, highest power first) held at its values at ``lo``
    and ``hi`` outside the angles it was fitted on: beyond them a fitted quadratic says nothing,
    and extrapolated it bends without limit (on a stiffness ramp, where σ drifts with time and
    the angle with it, by several times the torque across a gap)."""
    integral = np.polyint(coef)
    at_lo, at_hi = np.polyval(coef, np.array([lo, hi]))

    def elastic(y):
        y = np.asarray(y, dtype=float)
        return (np.polyval(integral, np.clip(y, lo, hi)) + at_lo * np.minimum(y - lo, 0.0)
                + at_hi * np.maximum(y - hi, 0.0))
    return elastic


def innovation_statistics(filtered: Filtered, *, inertia: float, damping: float, noise: NoiseLevels,
                          informed: np.ndarray | None = None) -> InnovationStatistics | None:
    """Whiteness of the innovations and their correlation with the velocity (None on fewer
    than :data:`MIN_STEPS` steps).

    Parameters
    ----------
    informed : ndarray of bool, shape (n,), optional
        The samples the motion informs the stiffness on; the statistics are then taken over the
        steps there only (pairs of steps both informed). Where the limb is held still the
        innovations say nothing about the stiffness, and a free motion dying out in a pause is a
        smooth, predictable residual of the noise-free kind (:data:`~limbstiff.checks.verdict.NEGLIGIBLE_RESIDUAL`).
    """
    st = _steps(filtered, inertia, damping)
    if len(st.index) < MIN_STEPS:
        return None
    e, s = kernels.kalman_innovations(st.increments, st.deflection, np.ascontiguousarray(st.measured),
                                      *noise.per_step(st.step), float(st.initial_mean[0]), float(st.initial_mean[1]),
                                      *map(float, st.initial_cov))
    skip = max(WHITENESS_LAGS, len(e) // 50)          # the diffuse start
    keep = np.ones(len(e) - skip, dtype=bool) if informed is None else np.asarray(informed, bool)[st.index][skip:]
    if keep.sum() < MIN_STEPS:
        return None
    u = e[skip:] / np.sqrt(s[skip:])
    v = filtered.velocity[st.index][skip:]
    u = np.where(keep, (u - u[keep].mean()) / max(float(u[keep].std()), 1e-300), 0.0)
    v = np.where(keep, (v - v[keep].mean()) / max(float(v[keep].std()), 1e-300), 0.0)
    n, count = len(u), int(keep.sum())
    lags = range(0, min(int(VELOCITY_LAG_S / st.step), n - 1) + 1)
    xcorr = [float(np.dot(u[k:], v[:n - k]) / count) for k in lags]
    return InnovationStatistics(autocorrelation=largest_autocorrelation(u, count),
                                velocity_correlation=max(map(abs, xcorr), default=0.0))


def largest_autocorrelation(u: np.ndarray, count: int, lags: int = WHITENESS_LAGS) -> float:
    """Largest |autocorrelation| at lags 1–``lags`` of ``u``, standardised over ``count`` samples
    (zero where left out), shape (n,): the whiteness statistic of the innovations (0 for n < 2)."""
    n = len(u)
    return max((abs(float(np.dot(u[:-k], u[k:]) / count)) for k in range(1, min(lags, n - 1) + 1)), default=0.0)


def stiffness_shift(filtered: Filtered, *, inertia: float, damping: float, other: tuple[float, float],
                    stiffness: np.ndarray, informed: np.ndarray) -> float | None:
    """Relative change of the stiffness were (m, b) replaced by ``other``.

    The Kalman model reads the stiffness from the elastic torque's increments over the angle's
    at its steps (ds = σ·dy); m' and b' in place of m and b change the elastic torque by
    −((m' − m)·ÿ + (b' − b)·ẏ), so the stiffness by the least-squares slope of that change's
    increments on the angle's, over pairs of informed steps. Returned over |median stiffness|
    (None when it cannot be computed).
    """
    st = _steps(filtered, inertia, damping)
    i = st.index
    change = (other[0] - inertia) * filtered.acceleration[i] + (other[1] - damping) * filtered.velocity[i]
    dy, dc = np.diff(filtered.angle[i]), np.diff(change)
    use = np.asarray(informed, bool)[i]
    use = use[1:] & use[:-1]
    median = abs(float(np.median(stiffness[informed])))
    spread = float(dy[use] @ dy[use]) if use.any() else 0.0
    if spread <= 0 or median <= 0:
        return None
    return float(-(dy[use] @ dc[use]) / spread / median)


def angle_terms_on(steps: ModelSteps, noise: NoiseLevels, *, motion_frequency: float,
                   beside: np.ndarray | None = None) -> AngleTerms | None:
    """The stiffness's change with the angle within the motion cycle
    (:func:`~limbstiff.estimate.angle_terms.fit_angle_terms`) on the model's ``steps`` and ``noise``
    (the analysis's own, with the Kalman estimator), fitted ``beside`` torques (k, m) the model lacks
    when given; None on fewer than :data:`MIN_STEPS` steps or when the motion cannot tell the terms apart."""
    if len(steps.index) < MIN_STEPS:
        return None
    return fit_angle_terms(steps, noise, motion_frequency=motion_frequency, beside=beside)


def angle_terms(filtered: Filtered, *, inertia: float, damping: float, noise: NoiseLevels) -> AngleTerms | None:
    """:func:`angle_terms_on` the model at m, b and ``noise``."""
    return angle_terms_on(_steps(filtered, inertia, damping), noise, motion_frequency=filtered.motion_hz)


def dynamic_variance(filtered: Filtered) -> float:
    """Variance of the torque above half the typical motion frequency, (N·m)²: the part the
    model's one-step predictions are about (a slowly moved operating point, a drift, a tonic
    contraction would otherwise make any residual look negligible)."""
    from .. import signals
    slow = signals.zero_phase_lowpass(filtered.torque, filtered.fs, 0.5 * filtered.motion_hz, order=2)
    return float(np.var(filtered.torque - slow))


def bound_margins(filtered: Filtered, *, inertia: float, damping: float, noise: NoiseLevels) -> np.ndarray:
    """How far each noise level lies below its upper bound, in natural-log units, shape (4,):
    measurement R, torque walk Q_s, stiffness walks Q_σ and Q_c (:func:`~limbstiff.statespace.noise.noise_bounds`)."""
    st = _steps(filtered, inertia, damping)
    bounds = np.array(noise_bounds(float(np.var(st.measured)), float(np.sqrt(st.initial_cov[2])), filtered.motion_hz))
    logs = noise.logs()
    return bounds[:, 1] - logs


def elastic_slopes(torque: np.ndarray, angle: np.ndarray, *, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares slope of ``torque`` on ``angle`` in consecutive windows, and the share of the
    torque's variance each line explains.

    Parameters
    ----------
    torque, angle : ndarray, shape (n,)
    window : int
        Samples per window.

    Returns
    -------
    slope : ndarray, shape (w,), N·m/rad
    explained : ndarray, shape (w,)
    """
    window = max(2, min(int(window), len(angle)))
    w = len(angle) // window
    y = angle[:w * window].reshape(w, window)
    f = torque[:w * window].reshape(w, window)
    yc = y - y.mean(axis=1, keepdims=True)
    fc = f - f.mean(axis=1, keepdims=True)
    yy = np.maximum(np.sum(yc * yc, axis=1), 1e-300)
    slope = np.sum(yc * fc, axis=1) / yy
    explained = slope * np.sum(yc * fc, axis=1) / np.maximum(np.sum(fc * fc, axis=1), 1e-300)
    return slope, explained
