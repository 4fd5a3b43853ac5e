"""Axes-level plots of a stiffness result: each draws onto an axes it is given (or the current
one) and returns it, so that a user can place them in their own figures, and the report's
pages are assembled from them (as python-control's plot functions are).

matplotlib is imported inside the functions only.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..digest import cycle_course, period_words, point_caption
from ..estimate.angle_terms import AngleCourse, AngleTerms, angle_course, fit_angle_terms
from ..estimate.observer import informed_samples
from ..statespace.steps import kalman_decimation, model_steps
from .common import LIMIT_VALUES, envelope, envelope_band, robust_limits, shade_false

#: Bins of the stiffness-against-angle/torque plots (equal counts of informed samples).
RELATION_BINS = 12
#: Informed samples per bin at least; fewer bins when the trial has fewer samples.
MIN_BIN_SAMPLES = 30
#: Points of the grey scatter behind the binned medians at most (evenly thinned beyond).
SCATTER_POINTS = 4000
#: Points of the smoothed course scattered behind the stiffness against angle at most.
COURSE_POINTS = 3000
#: Informed samples the bins are taken over at most (evenly thinned beyond: the medians of a long
#: trial are the same within print resolution, at a fraction of the memory).
BIN_SAMPLES = 500_000


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    return ax


def names(trial) -> dict[str, str]:
    """Words for the trial's quantities: angle/torque (rotational) or position/force."""
    if trial.kind == "translational":
        return {"angle": "position", "torque": "force", "elastic_torque": "elastic force"}
    return {"angle": "angle", "torque": "torque", "elastic_torque": "elastic torque"}


def recorded_torque(result) -> tuple[str, np.ndarray]:
    """The torque channel the variant used: (``torque`` or ``elastic_torque``, samples)."""
    trial = result.trial
    if result.variant == "direct" or trial.torque is None:
        return "elastic_torque", trial.elastic_torque
    return "torque", trial.torque


def plot_stiffness(result, *, ax=None, reference: bool = True, legend: bool = True, per_cycle: bool = True):
    """The stiffness over time with its band; stretches not informed by motion shaded grey.

    Parameters
    ----------
    result : StiffnessResult
    ax : matplotlib.axes.Axes, optional
        Where to draw (the current axes of pyplot when omitted).
    reference : bool
        Draw the reference stiffness (``stiffness_true`` or a calibration) when there is one.
    legend : bool
        Above the axes, in as many columns as its width holds.
    per_cycle : bool
        Draw the course at the resolution the data support: one median per motion cycle with the
        band typical for it (:func:`limbstiff.digest.cycle_course`, which says why), as page 1
        does; False draws every sample (page 2). Either way nothing is drawn where the samples are
        not informed by motion or lie at the filter's edges.

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = _axes(ax)
    t, u = result.trial.time, result.trial.units
    shade_false(ax, t, result.observable)
    if per_cycle:
        course = cycle_course(result)
        ax.fill_between(course.time, course.lo, course.hi, color="C0", alpha=0.3, lw=0,
                        label=f"{100 * result.ci_level:.0f} % band")
        noun, _ = period_words(result, course)
        ax.plot(course.time, course.stiffness, lw=1.0, color="C0", marker="o", ms=2.2,
                label=f"median per {noun}")
        values = [course.stiffness, course.lo, course.hi]
    else:
        values = _per_sample(ax, result)
    show_ref = reference and result.reference is not None
    if show_ref:
        ax.plot(*envelope(t, result.reference), lw=0.9, color="k", ls="--", label="reference")
        obs = np.flatnonzero(informed_samples(result.observable))
        values.append(result.reference[obs[::max(1, obs.size // LIMIT_VALUES)]])
    limits = robust_limits(np.concatenate(values), pad=0.2, pct=(0, 100) if per_cycle else (1, 99))
    if limits is not None:
        ax.set_ylim(*limits)
    ax.set_xlim(t[0], t[-1])
    ax.set_xlabel(f"time [s]  ({point_caption(result, course)})" if per_cycle else "time [s]")
    ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    if legend:
        ax.fill_between([], [], [], color="0.88", lw=0, label="not informed by motion")
        legend_above(ax)
    return ax


def _per_sample(ax, result) -> list[np.ndarray]:
    """Every sample's estimate and band, blank where not informed (or at the filter's edges); the
    values the axis limits are taken from."""
    t = result.trial.time
    use = np.asarray(result.observable, bool).copy()
    edge = int(getattr(result.filtered, "edge", 0) or 0)
    if edge:
        use[:edge] = use[use.size - edge:] = False
    if not use.any():
        use[:] = True                               # nothing informed: draw it all, all shaded grey
    ax.fill_between(*envelope_band(t, result.stiffness_lo, result.stiffness_hi, where=use), color="C0", alpha=0.3,
                    lw=0, label=f"{100 * result.ci_level:.0f} % band")
    ax.plot(*envelope(t, result.stiffness, where=use), lw=0.8, color="C0", label="estimate")
    obs = np.flatnonzero(use)
    obs = obs[::max(1, obs.size // LIMIT_VALUES)]
    return [result.stiffness[obs], result.stiffness_lo[obs], result.stiffness_hi[obs]]


#: Width of a legend entry besides its label (handle and spacing), in font sizes; of one character
#: of a label, on average (a generous estimate: a legend too wide for its axes is worse than a row more).
LEGEND_HANDLE_EM, LEGEND_CHAR_EM = 3.2, 0.62


def legend_columns(labels: list[str], width_in: float, fontsize: float) -> int:
    """The most columns (filled column by column, as matplotlib does) whose estimated width fits
    ``width_in`` inches of axes at ``fontsize`` pt; 1 at least."""
    em = fontsize / 72
    for n in range(len(labels), 1, -1):
        rows = -(-len(labels) // n)
        columns = [labels[j * rows:(j + 1) * rows] for j in range(n)]
        width = sum(LEGEND_HANDLE_EM * em + LEGEND_CHAR_EM * em * max(map(len, c)) for c in columns if c)
        if width <= width_in:
            return n
    return 1


def legend_above(ax) -> None:
    """The legend in as few rows as fit just above the axes: never over the data, nor wider than the
    axes (into a neighbouring plot)."""
    import matplotlib
    handles, labels = ax.get_legend_handles_labels()
    width_in = ax.get_position().width * ax.get_figure().get_figwidth()
    fontsize = matplotlib.font_manager.FontProperties(size=matplotlib.rcParams["legend.fontsize"]).get_size_in_points()
    ax.legend(handles, labels, loc="lower left", bbox_to_anchor=(0.0, 1.01),
              ncols=legend_columns(labels, width_in, fontsize), frameon=False, borderaxespad=0.0, handlelength=1.6,
              columnspacing=1.0)


class RelationBins(NamedTuple):
    """Stiffness in bins of angle or torque, each array of shape (k,) (one value per bin).

    Parameters
    ----------
    x : ndarray
        Median angle (rad, m) or torque (N·m, N) of the bin.
    median, p10, p90 : ndarray, N·m/rad (N/m)
        Median, 10th and 90th percentile of the estimate in the bin (its change over the trial).
    lo, hi : ndarray, N·m/rad (N/m)
        Medians of the band's bounds in the bin (the estimate's uncertainty there).
    count : ndarray of int
        Samples in the bin.
    """

    x: np.ndarray
    median: np.ndarray
    p10: np.ndarray
    p90: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    count: np.ndarray


def relation_bins(x: np.ndarray, stiffness: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  *, bins: int = RELATION_BINS) -> RelationBins:
    """Stiffness in bins of ``x`` with equal counts: median, spread over the trial and band.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Angle or torque of the informed samples.
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        Estimate and band bounds at those samples.
    bins : int
        Bins wanted; fewer when a bin would hold under :data:`MIN_BIN_SAMPLES`.

    Returns
    -------
    RelationBins
    """
    k = int(max(1, min(bins, x.size // MIN_BIN_SAMPLES)))
    order = np.argsort(x, kind="stable")
    groups = [g for g in np.array_split(order, k) if g.size]

    def per_bin(values, stat=np.median):
        return np.array([stat(values[g]) for g in groups])

    return RelationBins(x=per_bin(x), median=per_bin(stiffness), p10=per_bin(stiffness, lambda v: np.percentile(v, 10)),
                        p90=per_bin(stiffness, lambda v: np.percentile(v, 90)), lo=per_bin(lo), hi=per_bin(hi),
                        count=np.array([g.size for g in groups]))


def plot_relation(result, against: str = "angle", *, ax=None, bins: int = RELATION_BINS,
                  legend: bool = True):
    """Stiffness against angle or torque: medians in bins with the band, over the informed samples.

    Grey points are the informed samples (thinned); black dots are the medians of the estimate
    in bins of equal counts, their bars the median band in the bin (the estimate's uncertainty);
    the blue shading spans the 10th–90th percentiles of the estimate in the bin (how much the
    stiffness varies at that angle or torque over the trial).

    Parameters
    ----------
    result : StiffnessResult
    against : {"angle", "torque"}
    ax : matplotlib.axes.Axes, optional
    bins : int
    legend : bool
        Draw the legend, above the axes (a page of two such plots draws its own).

    Returns
    -------
    matplotlib.axes.Axes
    """
    if against not in ("angle", "torque"):
        raise ValueError(f"against must be 'angle' or 'torque' (or 'time' for StiffnessResult.plot), not {against!r}")
    ax = _axes(ax)
    trial, u, word = result.trial, result.trial.units, names(result.trial)
    key, x = ("angle", trial.angle) if against == "angle" else recorded_torque(result)
    ax.set_xlabel(f"{word[key]} [{u[key]}]")
    ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    obs = np.flatnonzero(result.observable)
    if obs.size == 0:
        ax.text(0.5, 0.5, "no sample is informed by motion", transform=ax.transAxes, ha="center")
        return ax
    thin = obs[::max(1, int(np.ceil(obs.size / SCATTER_POINTS)))]
    ax.scatter(x[thin], result.stiffness[thin], s=2, lw=0, color="0.6", alpha=0.5, rasterized=True,
               label="informed samples")
    obs = obs[::max(1, obs.size // BIN_SAMPLES)]
    b = relation_bins(x[obs], result.stiffness[obs], result.stiffness_lo[obs], result.stiffness_hi[obs], bins=bins)
    ax.fill_between(b.x, b.p10, b.p90, color="C0", alpha=0.2, lw=0, label="10th–90th percentile in the bin")
    ax.errorbar(b.x, b.median, yerr=[b.median - b.lo, b.hi - b.median], fmt="o-", color="k",
                ms=3.5, lw=0.9, capsize=2.5, label=f"median in the bin, median {100 * result.ci_level:.0f} % band")
    limits = robust_limits(np.concatenate([result.stiffness[thin], b.lo, b.hi]), pad=0.15, pct=(0.5, 99.5))
    if limits is not None:
        ax.set_ylim(*limits)
    if legend:
        legend_above(ax)
    return ax


class AngleFigure(NamedTuple):
    """What the stiffness-against-angle plot draws (:func:`angle_figure`).

    Parameters
    ----------
    course : AngleCourse
        The stiffness against the angle from the angle terms, with its band.
    angle, stiffness : ndarray, shape (k,)
        The smoothed course at the informed model steps (thinned), against the angle as the
        curve's: the operating angle plus the step's deflection, rad (m), N·m/rad (N/m).
    terms : AngleTerms
        The angle terms the curve is drawn from.
    """

    course: AngleCourse
    angle: np.ndarray
    stiffness: np.ndarray
    terms: AngleTerms


def angle_figure(result) -> AngleFigure | None:
    """The stiffness against the angle of a result, from its angle terms.

    The analysis fits the terms on its Kalman model's steps (:mod:`limbstiff.estimate.angle_terms`)
    and keeps only the check; they are fitted again here on the same steps (the filtered signals,
    m and b, the noise levels of the result: the same numbers, in a few hundredths of a second).
    The band adds the median stiffness's own interval to the terms' (in quadrature); a coupling
    the stiffness was corrected for maps curve and band to the limb's.

    Returns
    -------
    AngleFigure or None
        None when the terms were not fitted: another estimator than ``kalman``, too few steps,
        or a motion that cannot tell the terms apart (the check ``angle_dependence`` has no value).
    """
    checks = result.checks
    if result.estimator != "kalman" or checks is None or result.fit.noise is None:
        return None
    try:
        if checks["angle_dependence"].value is None:
            return None
    except KeyError:
        return None
    f = result.filtered
    m = 0.0 if result.inertia is None else float(result.inertia.median)
    b = 0.0 if result.damping is None else float(result.damping.median)
    steps = model_steps(f.angle, f.elastic_torque(m, b), sample_period=f.sample_period,
                        decimation=kalman_decimation(f.sample_period, f.cutoff_hz), edge=f.edge,
                        motion_frequency=f.motion_hz, scale_from=f.torque)
    terms = fit_angle_terms(steps, result.fit.noise, motion_frequency=f.motion_hz)
    if terms is None:
        return None
    informed = informed_samples(result.observable)[steps.index]
    limb = _limb_map(result)
    course = result.stiffness[steps.index]
    one_body = course if limb is None else _series(result, course)
    median = result.informed_stiffness()[0]
    half = 0.0
    if median.lo is not None and median.hi is not None and np.isfinite(median.hi - median.lo):
        half = 0.5 * float(median.hi - median.lo)
    if limb is not None:
        half = 0.0                       # the median's interval is the limb's: the terms' band alone
    found = angle_course(terms, steps, one_body, informed, level=result.ci_level, level_half=half)
    if limb is not None:
        found = replace(found, stiffness=limb(found.stiffness), lo=limb(found.lo), hi=limb(found.hi))
    shown = np.flatnonzero(informed)
    shown = shown[::max(1, int(np.ceil(shown.size / COURSE_POINTS)))]
    return AngleFigure(found, found.operating + steps.deflection[shown], course[shown], terms)


def _limb_map(result):
    """The map from the one-body stiffness to the limb's when the result's stiffness was corrected
    for a coupling (its check passed), else None."""
    coupling = result.coupling
    if coupling is None or not coupling.found:
        return None
    try:
        corrected = result.checks["device_coupling"].passed
    except KeyError:
        return None
    return coupling.limb_stiffness if corrected else None


def _series(result, limb_stiffness: np.ndarray) -> np.ndarray:
    """The springs-in-series stiffness K' = K·k_c/(K + k_c) of a limb's K (inverse of
    :meth:`~limbstiff.coupling.CouplingFit.limb_stiffness`)."""
    kc = result.coupling.coupling_stiffness
    return limb_stiffness * kc / (limb_stiffness + kc)


def angle_course_words(course: AngleCourse, unit_angle: str, unit_stiffness: str) -> str:
    """The curve of :class:`AngleCourse` in words: how the stiffness goes from one end of the
    angle range to the other (rises, falls, or is highest or lowest within it), with its values."""
    k, g = course.stiffness, course.deflection
    first, last, top, bottom = k[0], k[-1], int(np.argmax(k)), int(np.argmin(k))

    def at(i):
        return f"{k[i]:.3g} {unit_stiffness} at {g[i]:+.2g} {unit_angle}"

    where = f" (angles from the operating angle {course.operating:.3g} {unit_angle})"
    half = 0.5 * (course.hi - course.lo)

    def inside(i):
        """An extremum within the range, told from both ends by more than the band's half-width there."""
        return 0 < i < len(k) - 1 and min(abs(k[i] - first), abs(k[i] - last)) > half[i]

    if np.ptp(k) <= float(np.min(half)):
        return (f"the stiffness does not change with the angle beyond its band: about {np.median(k):.3g} "
                f"{unit_stiffness} from {g[0]:+.2g} to {g[-1]:+.2g} {unit_angle}{where}")
    if inside(top) and not inside(bottom):
        return (f"the stiffness is highest, {at(top)}, and lower towards both ends of the motion: "
                f"{at(0)}, {at(len(k) - 1)}{where}")
    if inside(bottom) and not inside(top):
        return (f"the stiffness is lowest, {at(bottom)}, and higher towards both ends of the motion: "
                f"{at(0)}, {at(len(k) - 1)}{where}")
    if inside(top) and inside(bottom):          # a parabola has one extremum: not reached
        return f"the stiffness goes from {at(0)} to {at(len(k) - 1)}{where}"
    verb = "rises" if last > first else "falls"
    return f"the stiffness {verb} from {at(0)} to {at(len(k) - 1)}{where}"


def plot_angle_course(ax, figure: AngleFigure, *, units: dict | None = None, word: str = "angle",
                      legend: bool = True):
    """The stiffness against the angle from the angle terms: the curve with its band over the
    central 95 % of the deflections, the smoothed course's samples lightly behind.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    figure : AngleFigure
        From :func:`angle_figure`.
    units : dict, optional
        The trial's units (``angle``, ``stiffness``); rad and N·m/rad when omitted.
    word : str
        What the angle is called (``position`` for a translational trial).
    legend : bool

    Returns
    -------
    matplotlib.axes.Axes
    """
    u = {"angle": "rad", "stiffness": "N·m/rad", **(units or {})}
    c = figure.course
    ax.scatter(figure.angle, figure.stiffness, s=2, lw=0, color="0.65", alpha=0.35, rasterized=True,
               label="smoothed course over time (model steps)")
    ax.fill_between(c.angle, c.lo, c.hi, color="C3", alpha=0.22, lw=0, label=f"{100 * c.level:.0f} % band")
    ax.plot(c.angle, c.stiffness, color="C3", lw=1.6, label=f"stiffness against {word} (within the cycle)")
    ax.axvline(c.operating, color="0.4", lw=0.6, ls=":")
    # the curve and its band whole, the scatter without its outliers
    values = np.concatenate([np.percentile(figure.stiffness, [0.5, 99.5]) if figure.stiffness.size else [],
                             c.lo, c.hi])
    limits = robust_limits(values, pad=0.1, pct=(0, 100))
    if limits is not None:
        ax.set_ylim(*limits)
    ax.set_xlim(c.angle[0] - 0.05 * np.ptp(c.angle), c.angle[-1] + 0.05 * np.ptp(c.angle))
    ax.set_xlabel(f"{word} [{u['angle']}]  (dotted: the operating {word}, {c.operating:.3g} {u['angle']})")
    ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    if legend:
        ax.legend(loc="upper right", framealpha=0.85)
    return ax


def plot_curve(curve, *, ax=None, **kwargs):
    """The stiffness by phase or by schedule (:func:`limbstiff.report.curve.plot_curve`)."""
    from .curve import plot_curve as draw
    return draw(curve, ax=ax, **kwargs)
