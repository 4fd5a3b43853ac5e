"""Where a model's one-step prediction errors lie, trial by trial.

The innovations of the nominal model (and of the model with the chosen effects), fitted on all
the data, are located in time, frequency and regime with the bounds of :mod:`.where`; the series
are kept for the plots. They are the model's one-step prediction errors at its steps: white,
unrelated to the motion and of the measurement noise's size when the model is right. Pure numpy:
no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import where
from ..effects.channels import Channels
from .where import Bin, CrossCorrelation, Spectrum, Whiteness

#: Confidence level of the "where" bounds.
WHERE_LEVEL = 0.95
#: Cross-correlation lags, s: beyond the longest reflex loop (80 ms) and channel shift (50 ms).
XCORR_LAG_S = 0.2
#: Lags of the whiteness test, steps.
WHITENESS_LAGS = 20


#: What the whiteness test of a model's innovations tells.
WHITENESS_NOTE = "innovations of the Kalman model: white when the model is right"


@dataclass(frozen=True, eq=False)
class GapOverTime:
    """The gap window by window, and where it changes.

    Parameters
    ----------
    window_s : float, s
        Length of a window.
    start_s : ndarray, shape (w,), s
        Time of each window's first scored step.
    end_s : float, s
        Time of the last scored step.
    gap : ndarray, shape (w,)
        Mean squared innovation in each window over the trial's mean squared torque deviation.
    change_points_s : ndarray, shape (c,), s
        Starts of the windows where the gap's level changes.
    """

    window_s: float
    start_s: np.ndarray
    end_s: float
    gap: np.ndarray
    change_points_s: np.ndarray


@dataclass(frozen=True)
class Regimes:
    """The gap binned by operating regime (:func:`where.binned_gap`), one tuple of bins each.

    Parameters
    ----------
    speed : tuple of Bin
        Near zero speed, then equally populated bins of |ẏ| (rad/s).
    reversal : tuple of Bin
        Away from, and within 1/8 motion period of, a reversal.
    angle, torque, stiffness : tuple of Bin
        Quintiles of y (rad), f (N·m) and the estimated stiffness (N·m/rad).
    """

    speed: tuple[Bin, ...]
    reversal: tuple[Bin, ...]
    angle: tuple[Bin, ...]
    torque: tuple[Bin, ...]
    stiffness: tuple[Bin, ...]


@dataclass(frozen=True)
class CrossCorrelations:
    """The innovations' cross-correlation with the filtered velocity and angle."""

    velocity: CrossCorrelation
    angle: CrossCorrelation


@dataclass(frozen=True)
class Where:
    """Where one trial's innovations lie.

    Parameters
    ----------
    time : GapOverTime
    frequency : Spectrum
        Innovations' spectrum against the torque's, coherence with the angle.
    regime : Regimes
    whiteness : Whiteness
        Of the innovations over their standard deviation, with the step as sample period.
    cross_correlation : CrossCorrelations
    """

    time: GapOverTime
    frequency: Spectrum
    regime: Regimes
    whiteness: Whiteness
    cross_correlation: CrossCorrelations


@dataclass(frozen=True, eq=False)
class TrialSeries:
    """One trial's innovations at its scored steps, for the plots (not written to JSON).

    Parameters
    ----------
    time : ndarray, shape (r,), s
    residual : ndarray, shape (r,), N·m
        The nominal model's innovations.
    torque : ndarray, shape (r,), N·m
        The filtered torque.
    where : Where
        Of the nominal model's innovations.
    residual_after : ndarray, shape (r,), N·m, or None
        The innovations of the model with the chosen effects (None: none chosen).
    where_after : Where or None
        Of ``residual_after``.
    """

    time: np.ndarray
    residual: np.ndarray
    torque: np.ndarray
    where: Where
    residual_after: np.ndarray | None = None
    where_after: Where | None = None


def locate(ch: Channels, lay, residual: np.ndarray) -> Where:
    """Where one trial's innovations lie: in time, frequency and regime; whiteness, cross-correlation.

    Parameters
    ----------
    ch : Channels
    lay : nominal.ScoringLayout
        The trial's steps; only the scored ones are used.
    residual : ndarray, shape (r,), N·m
        Innovations at the steps.

    Returns
    -------
    Where
    """
    keep = lay.scored
    rows, res = lay.rows[keep], residual[keep]
    f, y, v, t = ch.torque[rows], ch.angle[rows], ch.velocity[rows], ch.time[rows]
    dev_power = float(np.mean((f - f.mean()) ** 2))
    rate = 1.0 / lay.step_s
    wins = np.unique(lay.window[keep])
    win_gap = np.array([np.mean(res[lay.window[keep] == w] ** 2) / dev_power for w in wins])
    starts = [float(t[lay.window[keep] == w][0]) for w in wins]
    cps = where.change_points(np.log(np.maximum(win_gap, 1e-300)))
    time = GapOverTime(window_s=lay.window_s, start_s=np.array(starts), end_s=float(t[-1]), gap=win_gap,
                       change_points_s=np.array([starts[i] for i in cps], dtype=float))
    freq = where.spectrum(res, f, y, rate, level=WHERE_LEVEL)
    max_lag = int(min(WHITENESS_LAGS, len(res) // 5))
    white = replace(where.whiteness(res / max(float(np.std(res)), 1e-300), max_lag=max_lag, level=WHERE_LEVEL),
                    sample_period_s=lay.step_s, note=WHITENESS_NOTE)
    lags = max(1, int(round(XCORR_LAG_S * rate)))
    xcorr = CrossCorrelations(*(where.cross_correlation(res, x, max_lag=lags, sample_period=lay.step_s,
                                                        level=WHERE_LEVEL) for x in (v, y)))
    return Where(time=time, frequency=freq, regime=_regimes(ch, rows, res, dev_power), whiteness=white,
                 cross_correlation=xcorr)


def _regimes(ch: Channels, rows: np.ndarray, residual: np.ndarray, dev_power: float) -> Regimes:
    """The gap binned by speed, nearness to a reversal, angle, torque and stiffness.

    ``rows``: the residual's samples (r,); ``dev_power``: mean squared torque deviation (N·m²).
    """
    f, y, v = ch.torque[rows], ch.angle[rows], ch.velocity[rows]
    eff = where.effective_fraction(residual ** 2)
    # "near zero": below three velocity-noise levels, or 1 % of the RMS speed on noise-free data
    still = max(3.0 * ch.velocity_noise, 0.01 * float(np.sqrt(np.mean(v ** 2))))
    lab, names, rng = where.speed_bins(v, still)
    speed = where.binned_gap(residual, dev_power, lab, names, level=WHERE_LEVEL, effective=eff, edges=rng)
    near_full = where.reversal_mask(ch.velocity, int(round(0.125 * ch.fs / ch.motion_hz)), still)
    reversal = where.binned_gap(residual, dev_power, near_full[rows].astype(int),
                                ["away from reversals", "within 1/8 period of a reversal"],
                                level=WHERE_LEVEL, effective=eff)
    quintiles = []
    for x in (y, f, ch.stiffness[rows]):
        lab, rng = where.quantile_bins(x, 5)
        quintiles.append(tuple(where.binned_gap(residual, dev_power, lab, [f"{lo:.4g}–{hi:.4g}" for lo, hi in rng],
                                                level=WHERE_LEVEL, effective=eff, edges=rng)))
    return Regimes(tuple(speed), tuple(reversal), *quintiles)


def series(problem, nominal_eval, final_eval=None) -> dict[str, TrialSeries]:
    """Per trial, the nominal model's innovations (and the model's with the chosen effects) and
    where they lie.

    Parameters
    ----------
    problem : crossval.Problem
    nominal_eval, final_eval : crossval.Evaluation
        The nominal model and the model with the chosen effects (None: none chosen).

    Returns
    -------
    dict of str to TrialSeries
        By trial name, in the problem's order.
    """
    out = {}
    for i, (ch, lay) in enumerate(zip(problem.channels, problem.layouts)):
        sl, keep = problem.trial_rows(i), lay.scored
        res0 = nominal_eval.residual[sl]
        res1 = None if final_eval is None else final_eval.residual[sl]
        out[ch.name] = TrialSeries(time=ch.time[lay.rows[keep]], residual=res0[keep], torque=ch.torque[lay.rows[keep]],
                                   where=locate(ch, lay, res0), residual_after=None if res1 is None else res1[keep],
                                   where_after=None if res1 is None else locate(ch, lay, res1))
    return out
