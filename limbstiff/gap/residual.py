"""The full-rate residual of a model and where it lies, trial by trial.

The nominal model (and the model with the chosen effects) is refitted at full rate and its
residual located in time, frequency and regime with the bounds of :mod:`.where`; the series
are kept for the plots. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from . import crossval, nominal, where
from .channels import Channels

#: Confidence level of the "where" bounds.
WHERE_LEVEL = 0.95
#: Cross-correlation lags, s: beyond the longest reflex loop (80 ms) and channel shift (50 ms).
XCORR_LAG_S = 0.2


def full_residual(ch: Channels, components, coef: np.ndarray) -> tuple:
    """Full-rate residual of a model (nuisance refitted at full rate), with its layout.

    Parameters
    ----------
    ch : Channels
    components : sequence of (Effect, dict)
        The model's effects with their shapes.
    coef : ndarray, shape (p,)
        Their amplitudes.

    Returns
    -------
    layout : nominal.Layout
        Every usable row (no decimation).
    residual : ndarray, shape (r,), N·m
    """
    lay = nominal.layout(ch, decimation=1)
    chc, regs, local = crossval.compose(ch, components)
    rows = lay.rows
    z = chc.elastic_target()[rows]
    if regs:
        z = z - coef @ np.vstack(regs)[:, rows]
    loc = np.vstack(local)[:, rows].T if local else None
    proj = nominal.projector(chc.angle[rows], chc.time[rows], lay, loc)
    return lay, proj.project(z)


def locate(ch: Channels, lay, residual: np.ndarray, decimation: int) -> dict:
    """Where a residual lies: in time, frequency and regime; its whiteness and cross-correlation.

    Parameters
    ----------
    ch : Channels
    lay : nominal.Layout
        The rows of ``residual`` (full rate).
    residual : ndarray, shape (r,), N·m
    decimation : int
        Decimation of the scored rows (sets the effective sample count of the bounds).

    Returns
    -------
    dict
        ``time``, ``frequency``, ``regime``, ``whiteness``, ``cross_correlation``.
    """
    rows = lay.rows
    f = ch.torque[rows]
    dev_power = float(np.mean((f - f.mean()) ** 2))
    y, v = ch.angle[rows], ch.velocity[rows]
    t = ch.time[rows]
    # time: gap per window, change points of its logarithm
    wins = np.unique(lay.window)
    win_gap = np.array([np.mean(residual[lay.window == w] ** 2) / dev_power for w in wins])
    starts = [float(t[lay.window == w][0]) for w in wins]
    cps = where.change_points(np.log(np.maximum(win_gap, 1e-300)))
    time = {"window_s": lay.window_s, "start_s": starts, "end_s": float(t[-1]), "gap": win_gap.tolist(),
            "change_points_s": [starts[i] for i in cps]}
    freq = where.spectrum(residual, f, y, ch.fs, max_hz=min(0.5 * ch.fs, 2 * nominal.effective_cutoff(ch)),
                          level=WHERE_LEVEL)
    regime = _regimes(ch, rows, residual, decimation, dev_power)
    # whiteness at the rows' rate, against what filtered white noise would show
    dec = residual[::decimation]
    max_lag = int(min(20, len(dec) // 5))
    grid = np.linspace(0.0, 0.5 * ch.fs, 4097)
    ref = where.filtered_noise_acf(nominal.filter_power(grid, ch), grid, np.arange(max_lag + 1) * decimation / ch.fs)
    white = where.whiteness(dec, max_lag=max_lag, level=WHERE_LEVEL, reference=ref)
    white["sample_period_s"] = decimation / ch.fs
    white["note"] = ("reference: autocorrelation of white noise through the analysis's low-pass; the test is on "
                     "the departure from it")
    xcorr = {"velocity": where.cross_correlation(residual, v, max_lag=int(XCORR_LAG_S * ch.fs),
                                                 sample_period=1.0 / ch.fs, level=WHERE_LEVEL),
             "angle": where.cross_correlation(residual, y, max_lag=int(XCORR_LAG_S * ch.fs),
                                              sample_period=1.0 / ch.fs, level=WHERE_LEVEL)}
    return {"time": time, "frequency": freq, "regime": regime, "whiteness": white, "cross_correlation": xcorr}


def _regimes(ch: Channels, rows: np.ndarray, residual: np.ndarray, decimation: int,
             dev_power: float) -> dict:
    """The gap binned by speed, nearness to a reversal, angle, torque and stiffness.

    ``rows``: the residual's rows (r,); ``dev_power``: mean squared torque deviation (N·m²).
    """
    f, y, v = ch.torque[rows], ch.angle[rows], ch.velocity[rows]
    eff = where.effective_fraction(residual[::decimation] ** 2)
    # "near zero": below three velocity-noise levels, or 1 % of the RMS speed on noise-free data
    still = max(3.0 * ch.velocity_noise, 0.01 * float(np.sqrt(np.mean(v ** 2))))
    regime = {}
    lab, names, rng = where.speed_bins(v, still)
    regime["speed"] = where.binned_gap(residual, dev_power, lab, names, level=WHERE_LEVEL, effective=eff / decimation,
                                       edges=rng)
    near = where.reversal_mask(v, int(round(0.125 * ch.fs / ch.motion_hz)), still)
    regime["reversal"] = where.binned_gap(residual, dev_power, near.astype(int),
                                          ["away from reversals", "within 1/8 period of a reversal"],
                                          level=WHERE_LEVEL, effective=eff / decimation)
    for key, x in (("angle", y), ("torque", f), ("stiffness", ch.stiffness[rows])):
        lab, rng = where.quantile_bins(x, 5)
        regime[key] = where.binned_gap(residual, dev_power, lab, [f"{lo:.4g}–{hi:.4g}" for lo, hi in rng],
                                       level=WHERE_LEVEL, effective=eff / decimation, edges=rng)
    return regime


def series(channels, layouts, components, coef: np.ndarray) -> tuple[dict, dict]:
    """Per trial, where the nominal model misses (and the model with ``components``), and the
    full-rate residual series for the plots.

    Parameters
    ----------
    channels : sequence of Channels
    layouts : sequence of nominal.Layout
        The scored rows of each trial (their decimation).
    components : sequence of (Effect, dict)
        The chosen effects with their shapes (empty: the nominal model only).
    coef : ndarray
        Their amplitudes in the model with all of them.

    Returns
    -------
    where : dict
        Trial name to :func:`locate` of the nominal residual.
    series : dict
        Trial name to ``time`` (s), ``residual``, ``torque`` (N·m), ``where`` and, with
        components, ``residual_after`` and ``where_after``.
    """
    where_out, out = {}, {}
    for ch, lay in zip(channels, layouts):
        full_lay, res0 = full_residual(ch, [], np.zeros(0))
        w = locate(ch, full_lay, res0, lay.decimation)
        where_out[ch.name] = w
        s = {"time": ch.time[full_lay.rows], "residual": res0, "torque": ch.torque[full_lay.rows],
             "where": w}
        if components:
            _, res1 = full_residual(ch, components, coef)
            s["residual_after"] = res1
            s["where_after"] = locate(ch, full_lay, res1, lay.decimation)
        out[ch.name] = s
    return where_out, out
