"""The least-squares cross-check of a curve: the method labs used before limbstiff, computed beside it.

By phase (an ensemble): in each of the curve's phase bins, the torque τ̃, angle θ̃ and its
derivatives θ̃', θ̃'' with the cycles' mean at each phase taken off
(:func:`limbstiff.cycles.ensemble_mean`, as :mod:`.prepare` takes it off the angle and torque),
and τ̃ = K·θ̃ + B·θ̃' + I·θ̃'' + c fitted by least squares over every cycle's samples in the bin:
K, B, I and c of the bin's own. By schedule: the same fit in each schedule bin, over the samples
of every stretch (the held-out units) whose schedule falls in it, each stretch's slow trend taken
off first — the part of each channel quadratic in time and linear in the schedule within the
stretch (the operating point moving with the schedule; over a stretch of seconds the elastic
torque of a stiffness that changes with the schedule is quadratic in it). The signals are the
analysis's filtered ones, the same the model sees.

The interval resamples whole units with replacement — whole cycles of an ensemble, the
exchangeable pieces of the recording, so whatever differs from cycle to cycle, the model's misfit
included, widens it; for a schedule, blocks of one period of the motion (``motion_hz``, over
which its residual stays correlated), because a stretch crosses a bin of a slow sweep once — and
takes the percentile interval at the curve's level. A bin's K is not
given (NaN) where fewer than :data:`~.curve.MIN_BIN_CYCLES` units reach it, or where its angle
does not move apart from its velocity and acceleration: the angle's standard deviation in the
bin, once the parts that follow θ̃', θ̃'' and the constant are taken off (the Schur complement of
the bin's normal equations), is below the angle resolution the recording itself shows
(:attr:`limbstiff.filtered.Filtered.angle_resolution`: its quantisation step or noise). Pure numpy:
no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scipy.stats import norm

from .. import cycles
from .curve import MIN_BIN_CYCLES, ScheduleCurve, adjacent_correlation, resample_weights

#: Resamples of the units for the interval.
RESAMPLES = 200


@dataclass(frozen=True)
class LeastSquaresCurve:
    """The least-squares stiffness in each of the curve's bins.

    Parameters
    ----------
    stiffness, lo, hi : ndarray, shape (B,), N·m/rad (N/m)
        K of each bin and its percentile interval over resampled units; NaN where not informed.
    units : ndarray of int, shape (B,)
        Units (cycles or stretches) with samples in the bin.
    level : float
    adjacent_correlation : float
        Correlation of neighbouring bins' resampled K (median over the pairs): how far the bins
        are independent comparisons.
    how : str
        What was fitted, in words.
    """

    stiffness: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    units: np.ndarray
    level: float
    adjacent_correlation: float
    how: str

    @property
    def informed(self) -> np.ndarray:
        return np.isfinite(self.stiffness)

    def to_dict(self) -> dict:
        def floats(x):
            return [None if not np.isfinite(v) else float(v) for v in x]
        return {"stiffness": floats(self.stiffness), "lo": floats(self.lo), "hi": floats(self.hi),
                "ci_level": self.level, "informed_bins": int(self.informed.sum()), "how": self.how}


def phase_channels(signals: np.ndarray, phase: np.ndarray, *, bins: int) -> np.ndarray:
    """The channels ``signals`` (c, n) with the cycles' mean at each phase (n,) taken off, (c, n)."""
    return np.stack([x - cycles.ensemble_mean(x, phase, bins=bins) for x in signals])


def schedule_channels(signals: np.ndarray, u: np.ndarray, unit: np.ndarray, time: np.ndarray) -> np.ndarray:
    """The channels ``signals`` (c, n) with each stretch's slow trend taken off: within every unit
    ``unit`` (n,), the least-squares part of each channel in 1, time (n,) s, its square and the
    schedule ``u`` (n,)."""
    out = np.full_like(signals, np.nan, dtype=float)
    for k in np.unique(unit[unit >= 0]):
        at = np.flatnonzero((unit == k) & np.isfinite(u))
        if len(at) < 4:
            continue
        dt = time[at] - time[at].mean()
        x = np.column_stack([np.ones(len(at)), dt, dt * dt, u[at] - u[at].mean()])
        coef = np.linalg.lstsq(x, signals[:, at].T, rcond=None)[0]
        out[:, at] = signals[:, at] - (x @ coef).T
    return out


def _unit_sums(tau: np.ndarray, x: np.ndarray, which: np.ndarray, unit: np.ndarray, bins: int,
               units: int) -> tuple[np.ndarray, np.ndarray]:
    """The normal equations' sums X'X (bins, units, p, p) and X'τ (bins, units, p) of each unit in each bin."""
    key, p = which * units + unit, x.shape[1]
    xx = np.stack([np.bincount(key, x[:, i] * x[:, j], minlength=bins * units) for i in range(p) for j in range(p)],
                  axis=-1).reshape(bins, units, p, p)
    xy = np.stack([np.bincount(key, x[:, i] * tau, minlength=bins * units) for i in range(p)],
                  axis=-1).reshape(bins, units, p)
    return xx, xy


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """K (the first coefficient) of the normal equations a (..., p, p), b (..., p); NaN where singular."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = np.linalg.cond(a) < 1.0 / np.finfo(float).eps
    out = np.full(a.shape[:-2], np.nan)
    if ok.any():
        out[ok] = np.linalg.solve(a[ok], b[ok][..., None])[..., 0, 0]
    return out


def binned_least_squares(tau: np.ndarray, angle: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, *,
                         which: np.ndarray, unit: np.ndarray, bins: int, level: float, resolution: float,
                         rng: np.random.Generator, how: str) -> LeastSquaresCurve:
    """τ̃ = K·θ̃ + B·θ̃' + I·θ̃'' + c by least squares in each bin, its interval over resampled units.

    Parameters
    ----------
    tau, angle, velocity, acceleration : ndarray, shape (m,)
        The samples used (N·m, rad, rad/s, rad/s²), their slow part already taken off
        (:func:`phase_channels`, :func:`schedule_channels`).
    which : ndarray of int, shape (m,)
        Each sample's bin, 0…bins − 1.
    unit : ndarray of int, shape (m,)
        Each sample's unit (cycle or stretch), 0…U − 1.
    bins : int
    level : float
        Of the interval.
    resolution : float, rad
        The angle resolution of the recording (module docstring).
    rng : numpy.random.Generator
    how : str
    """
    scale = np.array([np.std(angle), np.std(velocity), np.std(acceleration), 1.0])
    scale[scale == 0] = 1.0
    x = np.column_stack([angle, velocity, acceleration, np.ones(len(tau))]) / scale
    n_units = int(unit.max()) + 1
    xx, xy = _unit_sums(tau, x, which, unit, bins, n_units)
    per_bin = np.count_nonzero(xx[:, :, 3, 3] > 0, axis=1)
    a, b = xx.sum(axis=1), xy.sum(axis=1)
    k = _solve(a, b) / scale[0]
    n = np.maximum(a[:, 3, 3], 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        # the angle's variance apart from θ̃', θ̃'' and c: 1 / (a⁻¹)₀₀ per sample
        partial_sd = scale[0] / np.sqrt(np.abs(np.linalg.pinv(a, hermitian=True)[:, 0, 0]) * n)
    informed = (per_bin >= MIN_BIN_CYCLES) & (partial_sd > resolution) & np.isfinite(k)
    weights = resample_weights(n_units, RESAMPLES, rng)                                 # (R, U)
    kr = _solve(np.einsum("ru,bupq->rbpq", weights, xx), np.einsum("ru,bup->rbp", weights, xy)) / scale[0]
    lo, hi = np.full((2, bins), np.nan)
    if informed.any():
        lo[informed], hi[informed] = np.nanquantile(kr[:, informed], [0.5 - level / 2, 0.5 + level / 2], axis=0)
    k = np.where(informed, k, np.nan)
    return LeastSquaresCurve(k, lo, hi, per_bin, level, adjacent_correlation(kr[:, informed]), how)


def curve_least_squares(filtered, prepared, edges: np.ndarray, observable: np.ndarray, *, level: float,
                        rng: np.random.Generator) -> LeastSquaresCurve:
    """The cross-check on the curve's bins ``edges`` (B + 1,) from the analysis's filtered signals.

    Parameters
    ----------
    filtered : Filtered
        The analysis's filtered angle, velocity, acceleration and torque (n,).
    prepared : ScheduleInput
        Its phase or schedule ``u``, cycles and held-out units.
    edges : ndarray, shape (B + 1,)
    observable : ndarray of bool, shape (n,)
        The samples the analysis's motion informs.
    level : float
    rng : numpy.random.Generator
    """
    signals = np.stack([filtered.torque, filtered.angle, filtered.velocity, filtered.acceleration])
    u, unit = prepared.u, prepared.held_out
    if prepared.against == "phase":
        signals = phase_channels(signals, u, bins=prepared.mean_bins)
        how = ("K, B, I and a constant fitted in each phase bin over every cycle's samples, the cycles' mean at "
               "each phase taken off; interval: whole cycles resampled")
    else:
        signals = schedule_channels(signals, u, unit, np.arange(filtered.n) * filtered.sample_period)
        unit = np.arange(filtered.n) // max(1, int(round(filtered.fs / filtered.motion_hz)))
        how = ("K, B, I and a constant fitted in each schedule bin over the stretches' samples, each stretch's "
               "part quadratic in time and linear in the schedule taken off; interval: blocks of one period of "
               "the motion resampled")
    edge = np.zeros(filtered.n, dtype=bool)
    edge[filtered.edge:filtered.n - filtered.edge] = True
    use = np.flatnonzero(observable & edge & np.isfinite(u) & np.isfinite(signals).all(axis=0) & (unit >= 0))
    bins = len(edges) - 1
    which = np.clip(np.searchsorted(edges, u[use], side="right") - 1, 0, bins - 1)
    unit = np.unique(unit[use], return_inverse=True)[1]                  # numbered 0…U − 1
    return binned_least_squares(*signals[:, use], which=which, unit=unit, bins=bins, level=level,
                                resolution=filtered.angle_resolution, rng=rng, how=how)


def effective_bins(n: int, correlation: float) -> float:
    """The independent comparisons ``n`` bins are worth when neighbours' errors correlate
    ``correlation``: n·(1 − ρ)/(1 + ρ) (the effective size of an AR(1) mean), at least 1."""
    rho = float(np.clip(correlation, 0.0, 0.99))
    return max(1.0, n * (1 - rho) / (1 + rho))


def misfit_share(curve: ScheduleCurve, ls: LeastSquaresCurve) -> float:
    """The curve's error beyond its band, measured against the least-squares fit, as a share of
    the stiffness (rms over the bins where both are given): the largest the data do not exclude.

    Were the fit unbiased, E[(K_m − K_ls)²] = e² + σ_m² + σ_ls² in each bin, e the curve's own
    error and σ each band's half-width over its normal quantile: the mean over the bins of
    t = ((K_m − K_ls)² − σ_m² − σ_ls²)/K_m² estimates the mean squared relative error e²/K² that
    the curve's band does not hold (a bias of the fit makes it larger: the band wider, not
    narrower). Its upper one-sided bound at the curve's level is taken — the mean plus that many
    standard errors of t over the bins' effective number (neighbours correlate as the two bands'
    draws do) — so that a fit less precise than the curve cannot vouch for the curve's band; 0
    when even that is negative.
    """
    both = curve.informed & ls.informed & (curve.stiffness != 0)
    if both.sum() < 2:
        return 0.0
    z = norm.isf((1 - curve.level) / 2)
    sm, sl = (curve.hi - curve.lo)[both] / (2 * z), (ls.hi - ls.lo)[both] / (2 * z)
    d = (curve.stiffness - ls.stiffness)[both]
    t = (d * d - sm * sm - sl * sl) / curve.stiffness[both] ** 2
    var_m, var_ls = np.median(sm * sm), np.median(sl * sl)
    rho = (curve.adjacent_correlation * var_m + ls.adjacent_correlation * var_ls) / max(var_m + var_ls, 1e-300)
    upper = t.mean() + norm.isf(1 - curve.level) * t.std(ddof=1) / np.sqrt(effective_bins(len(t), rho))
    return float(np.sqrt(upper)) if upper > 0 else 0.0
