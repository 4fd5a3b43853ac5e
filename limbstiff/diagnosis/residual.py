"""Where a model's one-step prediction errors lie, trial by trial.

The innovations of the nominal model (and of the model with the chosen effects), fitted on all
the data, are located in time, frequency and regime with the bounds of :mod:`.where`; the series
are kept for the plots. They are the model's one-step prediction errors at its steps: white,
unrelated to the motion and of the measurement noise's size when the model is right. Pure numpy:
no I/O.
"""

from __future__ import annotations

import numpy as np

from . import where
from .channels import Channels

#: Confidence level of the "where" bounds.
WHERE_LEVEL = 0.95
#: Cross-correlation lags, s: beyond the longest reflex loop (80 ms) and channel shift (50 ms).
XCORR_LAG_S = 0.2
#: Lags of the whiteness test, steps.
WHITENESS_LAGS = 20


def locate(ch: Channels, lay, residual: np.ndarray) -> dict:
    """Where one trial's innovations lie: in time, frequency and regime; whiteness, cross-correlation.

    Parameters
    ----------
    ch : Channels
    lay : nominal.Layout
        The trial's steps; only the scored ones are used.
    residual : ndarray, shape (r,), N·m
        Innovations at the steps.

    Returns
    -------
    dict
        ``time``, ``frequency``, ``regime``, ``whiteness``, ``cross_correlation``.
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
    time = {"window_s": lay.window_s, "start_s": starts, "end_s": float(t[-1]), "gap": win_gap.tolist(),
            "change_points_s": [starts[i] for i in cps]}
    freq = where.spectrum(res, f, y, rate, level=WHERE_LEVEL)
    regime = _regimes(ch, rows, res, dev_power)
    max_lag = int(min(WHITENESS_LAGS, len(res) // 5))
    white = where.whiteness(res / max(float(np.std(res)), 1e-300), max_lag=max_lag, level=WHERE_LEVEL)
    white["sample_period_s"] = lay.step_s
    white["note"] = "innovations of the Kalman model: white when the model is right"
    lags = max(1, int(round(XCORR_LAG_S * rate)))
    xcorr = {name: where.cross_correlation(res, x, max_lag=lags, sample_period=lay.step_s, level=WHERE_LEVEL)
             for name, x in (("velocity", v), ("angle", y))}
    return {"time": time, "frequency": freq, "regime": regime, "whiteness": white, "cross_correlation": xcorr}


def _regimes(ch: Channels, rows: np.ndarray, residual: np.ndarray, dev_power: float) -> dict:
    """The gap binned by speed, nearness to a reversal, angle, torque and stiffness.

    ``rows``: the residual's samples (r,); ``dev_power``: mean squared torque deviation (N·m²).
    """
    f, y, v = ch.torque[rows], ch.angle[rows], ch.velocity[rows]
    eff = where.effective_fraction(residual ** 2)
    # "near zero": below three velocity-noise levels, or 1 % of the RMS speed on noise-free data
    still = max(3.0 * ch.velocity_noise, 0.01 * float(np.sqrt(np.mean(v ** 2))))
    regime = {}
    lab, names, rng = where.speed_bins(v, still)
    regime["speed"] = where.binned_gap(residual, dev_power, lab, names, level=WHERE_LEVEL, effective=eff, edges=rng)
    near_full = where.reversal_mask(ch.velocity, int(round(0.125 * ch.fs / ch.motion_hz)), still)
    regime["reversal"] = where.binned_gap(residual, dev_power, near_full[rows].astype(int),
                                          ["away from reversals", "within 1/8 period of a reversal"],
                                          level=WHERE_LEVEL, effective=eff)
    for key, x in (("angle", y), ("torque", f), ("stiffness", ch.stiffness[rows])):
        lab, rng = where.quantile_bins(x, 5)
        regime[key] = where.binned_gap(residual, dev_power, lab, [f"{lo:.4g}–{hi:.4g}" for lo, hi in rng],
                                       level=WHERE_LEVEL, effective=eff, edges=rng)
    return regime


def series(problem, nominal_eval, final_eval=None) -> tuple[dict, dict]:
    """Per trial, where the nominal model misses (and the model with the chosen effects), and the
    innovation series for the plots.

    Parameters
    ----------
    problem : crossval.Problem
    nominal_eval, final_eval : crossval.Evaluation
        The nominal model and the model with the chosen effects (None: none chosen).

    Returns
    -------
    where : dict
        Trial name to :func:`locate` of the nominal innovations.
    series : dict
        Trial name to ``time`` (s), ``residual``, ``torque`` (N·m), ``where`` and, with chosen
        effects, ``residual_after`` and ``where_after``.
    """
    where_out, out = {}, {}
    for i, (ch, lay) in enumerate(zip(problem.channels, problem.layouts)):
        sl = problem.trial_rows(i)
        res0 = nominal_eval.residual[sl]
        w = locate(ch, lay, res0)
        where_out[ch.name] = w
        keep = lay.scored
        s = {"time": ch.time[lay.rows[keep]], "residual": res0[keep], "torque": ch.torque[lay.rows[keep]],
             "where": w}
        if final_eval is not None:
            res1 = final_eval.residual[sl]
            s["residual_after"] = res1[keep]
            s["where_after"] = locate(ch, lay, res1)
        out[ch.name] = s
    return where_out, out
