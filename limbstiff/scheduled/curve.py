"""The stiffness against the cycle's phase or the schedule: the course pooled by bins, its band.

Each bin's stiffness is the mean of the course (walk plus curve, :func:`.fit.with_curve`) over
the informed samples whose phase (or schedule) falls in it, pooled over every cycle. Its band is
the same mean taken over joint posterior draws of the course: the simulation smoother's draws of
the walk (:func:`~limbstiff.estimate.course_draws.course_deviations`) plus posterior draws of m,
b, the effects' amplitudes and the curve's weights through the course's responses to them — the
posterior of the analysis's own band, pooled. The band published is the envelope of that and of
the band measured from the data (issue 46): each unit's (cycle's or stretch's) own mean of the
course in the bin, the units resampled with replacement and the bin's mean over them taken again,
its percentile interval at the same level — so that how much the course differs from cycle to
cycle shows in the band even where the model's posterior is sure of itself. The spread from
cycle to cycle is that of each cycle's own mean in the bin. Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..estimate.course_draws import course_deviations

#: Bins of the phase (0–1) and of the schedule (between its 1st and 99th percentiles).
PHASE_BINS, SCHEDULE_BINS = 50, 30
#: Joint draws of the course the bins' bands are taken from.
CURVE_DRAWS = 200
#: A bin needs informed samples from this many cycles (ensembles) or this many informed samples
#: (schedules: the model's steps in the bin times the samples per step) for a stiffness.
MIN_BIN_CYCLES, MIN_BIN_SAMPLES = 3, 50


@dataclass(frozen=True)
class ScheduleCurve:
    """Stiffness against the phase or the schedule, with its band.

    Parameters
    ----------
    against : {"phase", "schedule"}
    unit : str
        Of the schedule ("1" for the phase).
    at : ndarray, shape (B,)
        Bin centres: phase 0–1, or the schedule in its unit.
    edges : ndarray, shape (B + 1,)
    stiffness, lo, hi : ndarray, shape (B,), N·m/rad (N/m)
        Mean course in each bin and its ``level`` band (the envelope of the posterior's and the
        resampled units'); NaN where the bin is not informed.
    count : ndarray of int, shape (B,)
        Cycles (ensembles) or informed samples (schedules) in each bin.
    spread_lo, spread_hi : ndarray, shape (B,), N·m/rad
        10th and 90th percentiles of the cycles' own means in the bin (ensembles; NaN otherwise).
    level : float
    knots : ndarray
        The curve's knots (phase or schedule).
    posterior_lo, posterior_hi : ndarray, shape (B,), N·m/rad
        The posterior's band alone (before the envelope).
    adjacent_correlation : float
        Correlation of neighbouring bins' posterior draws (median over the pairs).
    misfit : float
        The error beyond the band measured against the least-squares cross-check, as a share of
        the stiffness (:meth:`widened`; 0 before).
    interpolation : ndarray, shape (B,), N·m/rad, or None
        The curve's interpolation error between its knots in each bin (:func:`interpolation_error`;
        :meth:`widened`; None before).
    """

    against: str
    unit: str
    at: np.ndarray
    edges: np.ndarray
    stiffness: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    count: np.ndarray
    spread_lo: np.ndarray
    spread_hi: np.ndarray
    level: float
    knots: np.ndarray
    posterior_lo: np.ndarray
    posterior_hi: np.ndarray
    adjacent_correlation: float = 0.0
    misfit: float = 0.0
    interpolation: np.ndarray | None = None

    def widened(self, misfit: float, interpolation: np.ndarray | None = None) -> "ScheduleCurve":
        """The curve with its band widened by an error of ``misfit`` × the stiffness (sd) and by
        ``interpolation`` (B,), N·m/rad, the curve's interpolation error between its knots
        (:func:`interpolation_error`), added in quadrature to the posterior's half-width (the
        misfit at the level's normal quantile); the envelope with the band it had kept."""
        from scipy.stats import norm
        z = norm.isf((1 - self.level) / 2)
        extra = np.zeros(len(self.at)) if interpolation is None else np.nan_to_num(np.asarray(interpolation, float))
        half = np.sqrt(((self.posterior_hi - self.posterior_lo) / 2) ** 2 + (z * misfit * self.stiffness) ** 2
                       + extra ** 2)
        return dataclasses.replace(self, lo=np.fmin(self.lo, self.stiffness - half),
                                   hi=np.fmax(self.hi, self.stiffness + half), misfit=float(misfit),
                                   interpolation=None if interpolation is None else extra)

    @property
    def count_name(self) -> str:
        return "n_cycles" if self.against == "phase" else "n_samples"

    @property
    def informed(self) -> np.ndarray:
        return np.isfinite(self.stiffness)

    def to_frame(self):
        """``stiffness_by_phase.csv`` / ``stiffness_by_schedule.csv`` as a DataFrame: the bin
        centre (``phase`` or ``schedule``), ``stiffness``, ``stiffness_lo``, ``stiffness_hi``
        (N·m/rad) and ``n_cycles`` or ``n_samples``."""
        import pandas as pd
        return pd.DataFrame({self.against: self.at, "stiffness": self.stiffness, "stiffness_lo": self.lo,
                             "stiffness_hi": self.hi, self.count_name: self.count})

    to_pandas = to_frame

    def to_dict(self) -> dict:
        """JSON-ready (``by_phase`` / ``by_schedule`` of ``summary.json``)."""
        ok = self.informed
        med = float(np.median(self.stiffness[ok])) if ok.any() else None
        return {"against": self.against, "unit": self.unit, "ci_level": self.level, "bins": len(self.at),
                "informed_bins": int(ok.sum()), "knots": [float(k) for k in self.knots],
                "median": med,
                "min": float(np.min(self.stiffness[ok])) if ok.any() else None,
                "max": float(np.max(self.stiffness[ok])) if ok.any() else None,
                "cycle_spread": None if self.against != "phase" else
                {"p10": _floats(self.spread_lo), "p90": _floats(self.spread_hi)},
                "band": {"from": "envelope of the posterior's band, the units' resampled means and the posterior's "
                                 "widened by the misfit against the least-squares cross-check and by the curve's "
                                 "interpolation error between its knots",
                         "width_ratio": self.width_ratio, "misfit_share": self.misfit,
                         "interpolation_share": self.interpolation_share}}

    @property
    def interpolation_share(self) -> float | None:
        """The interpolation error over the stiffness, median over the informed bins (None before
        :meth:`widened`)."""
        ok = self.informed & (self.stiffness != 0)
        if self.interpolation is None or not ok.any():
            return None
        return float(np.median(self.interpolation[ok] / np.abs(self.stiffness[ok])))

    @property
    def width_ratio(self) -> float | None:
        """The band's width over the posterior's alone, median over the informed bins."""
        ok = self.informed & (self.posterior_hi > self.posterior_lo)
        return float(np.median((self.hi - self.lo)[ok] / (self.posterior_hi - self.posterior_lo)[ok])) if ok.any() \
            else None


def interpolation_error(basis, weights: np.ndarray, edges: np.ndarray, *, points: int = 21) -> np.ndarray:
    """Each bin's mean of the curve's interpolation error between its knots
    (:meth:`~.basis.StiffnessBasis.interpolation_error` of ``basis`` at ``weights``, (J − 1,)), over
    ``points`` evenly spaced points of each bin of ``edges`` (B + 1,): shape (B,), N·m/rad. Linear
    interpolation misses a curved stiffness by the same sign across a knot interval, so the bin's
    mean misses it by the mean of the errors."""
    u = np.linspace(edges[:-1], edges[1:], points, axis=1)          # (B, points)
    return basis.interpolation_error(weights, u.ravel()).reshape(u.shape).mean(axis=1)


def _floats(x: np.ndarray) -> list:
    return [None if not np.isfinite(v) else float(v) for v in x]


def bin_edges(against: str, u: np.ndarray) -> np.ndarray:
    """Bin edges: :data:`PHASE_BINS` over 0–1, or :data:`SCHEDULE_BINS` over the schedule's 1st–99th
    percentiles."""
    if against == "phase":
        return np.linspace(0.0, 1.0, PHASE_BINS + 1)
    lo, hi = np.percentile(u[np.isfinite(u)], [1, 99])
    return np.linspace(lo, hi, SCHEDULE_BINS + 1)


def _bin_means(values: np.ndarray, which: np.ndarray, bins: int) -> np.ndarray:
    """Mean of ``values`` (..., m) per bin ``which`` (m,), shape (..., bins); NaN where empty."""
    count = np.bincount(which, minlength=bins).astype(float)
    sums = np.stack([np.bincount(which, weights=v, minlength=bins) for v in np.atleast_2d(values)])
    with np.errstate(invalid="ignore", divide="ignore"):
        out = sums / count
    return out if values.ndim > 1 else out[0]


def curve_draws(estimate, ident, steps: np.ndarray, *, draws: int, rng: np.random.Generator) -> np.ndarray:
    """Joint posterior draws of the course (draws, s) at the model's steps ``steps`` (s,) (indices
    into the estimate's steps), less the course itself."""
    dev = (course_deviations(estimate.steps, estimate.fit.noise, draws=draws, rng=rng, columns=steps)
           if estimate.steps is not None else np.zeros((draws, len(steps))))
    if ident is not None and ident.posterior is not None and estimate.sensitivity is not None:
        coef = ident.coefficient_draws
        coef = coef[rng.integers(0, len(coef), draws)]
        samples = estimate.steps.index[steps]
        dev = dev + (coef - ident.coefficients) @ estimate.sensitivity[:coef.shape[1], samples]
    return dev


def adjacent_correlation(draws: np.ndarray) -> float:
    """The median correlation of neighbouring columns of ``draws`` (R, B) over the pairs (0 when
    there are none): how much a bin's error goes with its neighbour's."""
    ok = np.isfinite(draws).all(axis=0) & (np.nanstd(draws, axis=0) > 0)
    d = draws[:, ok]
    if d.shape[1] < 2:
        return 0.0
    z = (d - d.mean(axis=0)) / d.std(axis=0)
    return float(np.median(np.mean(z[:, 1:] * z[:, :-1], axis=0)))


def _unit_sums(values: np.ndarray, which: np.ndarray, unit: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Samples and sums of ``values`` (m,) of each unit ``unit`` (m,) in each bin ``which`` (m,), (bins, U) each."""
    units = int(unit.max()) + 1
    key = which * units + unit
    hits = np.bincount(key, minlength=bins * units).reshape(bins, units).astype(float)
    return hits, np.bincount(key, weights=values, minlength=bins * units).reshape(bins, units)


def resample_weights(units: int, draws: int, rng: np.random.Generator) -> np.ndarray:
    """How often each of ``units`` units is drawn in each of ``draws`` resamples with replacement,
    shape (draws, units): the whole-unit bootstrap of the curve's band and of its least-squares
    cross-check."""
    return np.stack([np.bincount(d, minlength=units) for d in rng.integers(0, units, (draws, units))]).astype(float)


def resampled_band(hits: np.ndarray, sums: np.ndarray, *, level: float, rng: np.random.Generator,
                   draws: int = CURVE_DRAWS) -> tuple[np.ndarray, np.ndarray]:
    """The band of each bin's mean over the units, the units resampled with replacement: from each
    unit's samples ``hits`` and sums ``sums`` (bins, U) in each bin, the ``level`` percentile
    interval of the resampled means, (bins,) each; NaN where a bin has no samples."""
    weights = resample_weights(hits.shape[1], draws, rng)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = (weights @ sums.T) / (weights @ hits.T)                 # (draws, bins)
    out = np.full((2, hits.shape[0]), np.nan)
    some = np.isfinite(means).any(axis=0)
    out[:, some] = np.nanquantile(means[:, some], [0.5 - level / 2, 0.5 + level / 2], axis=0)
    return out[0], out[1]


def schedule_curve(estimate, ident, *, against: str, u: np.ndarray, cycle: np.ndarray | None, units: np.ndarray,
                   observable: np.ndarray, stiffness: np.ndarray, level: float, unit: str, knots: np.ndarray,
                   rng: np.random.Generator) -> ScheduleCurve:
    """The curve (module docstring) from the analysis's course ``stiffness`` (n,) and its estimate.

    Parameters
    ----------
    estimate : Estimate
        The Kalman estimate with the curve added (:func:`.fit.with_curve`): its steps give the draws.
    ident : Identification or None
    against : {"phase", "schedule"}
    u : ndarray, shape (n,)
        Phase or schedule at every sample (NaN outside).
    cycle : ndarray of int, shape (n,), or None
        Each sample's cycle (ensembles).
    units : ndarray of int, shape (n,)
        Each sample's held-out unit (its cycle, or its stretch of a schedule), resampled for the band.
    observable : ndarray of bool, shape (n,)
        Informed samples.
    stiffness : ndarray, shape (n,)
        The course reported (``stiffness.csv``).
    level : float
    unit : str
    knots : ndarray
    rng : numpy.random.Generator
    """
    edges = bin_edges(against, u)
    bins = len(edges) - 1
    idx = estimate.steps.index
    use = np.flatnonzero(observable[idx] & np.isfinite(u[idx]) & (units[idx] >= 0))
    samples = idx[use]
    which = np.clip(np.searchsorted(edges, u[samples], side="right") - 1, 0, bins - 1)
    centre = _bin_means(stiffness[samples], which, bins)
    dev = _bin_means(curve_draws(estimate, ident, use, draws=CURVE_DRAWS, rng=rng), which, bins)
    post = np.quantile(centre + dev, [0.5 - level / 2, 0.5 + level / 2], axis=0)
    hits, sums = _unit_sums(stiffness[samples], which, units[samples], bins)
    data = resampled_band(hits, sums, level=level, rng=rng)
    lo, hi = np.fmin(post[0], data[0]), np.fmax(post[1], data[1])
    spread = np.full((2, bins), np.nan)
    if cycle is not None:
        count = np.count_nonzero(hits, axis=1)
        enough = count >= MIN_BIN_CYCLES
        if enough.any():
            with np.errstate(invalid="ignore", divide="ignore"):
                per_cycle = sums / hits                 # each cycle's own mean, NaN where it has none there
            spread[:, enough] = np.nanpercentile(per_cycle[enough], [10, 90], axis=1)
    else:
        # each model step stands for the samples between it and the next
        count = np.bincount(which, minlength=bins) * int(np.median(np.diff(idx))) if len(idx) > 1 else \
            np.bincount(which, minlength=bins)
        enough = count >= MIN_BIN_SAMPLES
    centre, lo, hi, post_lo, post_hi = (np.where(enough, x, np.nan) for x in (centre, lo, hi, *post))
    return ScheduleCurve(against, unit, (edges[:-1] + edges[1:]) / 2, edges, centre, lo, hi, count,
                         spread[0], spread[1], level, np.asarray(knots, dtype=float), post_lo, post_hi,
                         adjacent_correlation(dev[:, enough]))
