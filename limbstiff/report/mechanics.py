"""The inertia–damping page of the per-trial report: the posterior of (m, b) as a pairwise
(corner) plot with the priors' densities drawn on its histograms (or "flat on > 0" said), the
least-squares and maximum-likelihood values (an arrow at the edge when off the plot), and the
posterior of the Kalman model's noise levels.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..digest import shape_text
from ..interval import Interval
from ..statespace.noise import NoiseLevels
from ..mechanics.posterior import prior_density
from ..protocol import Prior
from .common import FONT, fmt, grid, new_page, text_panel

#: Credible masses drawn as contours on the (m, b) scatter.
CONTOUR_MASSES = (0.5, 0.9)


def _prior_text(prior: Prior) -> str:
    """A prior in words."""
    if prior.distribution == "lognormal":
        return f"lognormal, median {prior.median:.4g}, sd of log {prior.sigma:.3g}"
    if prior.distribution == "uniform":
        return f"uniform on [{prior.low:.4g}, {prior.high:.4g}]"
    return "flat on > 0" if prior.scale is None else f"half-normal, scale {prior.scale:.4g}"


def _limits(x: np.ndarray, extra: list[float]) -> tuple[tuple[float, float], list[bool]]:
    """Axis range of the draws, widened to show the extra points that lie near it.

    Returns the range and, per extra point, whether it is inside it.
    """
    lo, hi = np.percentile(x, [0.25, 99.75])
    span = hi - lo if hi > lo else max(abs(hi), 1e-12) * 0.1
    lo, hi = lo - 0.1 * span, hi + 0.1 * span
    inside = []
    for v in extra:
        ok = v is not None and np.isfinite(v) and lo - 2 * span <= v <= hi + 2 * span
        inside.append(bool(ok))
        if ok:
            lo, hi = min(lo, v - 0.05 * span), max(hi, v + 0.05 * span)
    return (lo, hi), inside


def _contours(ax, x, y, xlim, ylim) -> None:
    """Contours enclosing :data:`CONTOUR_MASSES` of the draws (a smoothed 2-D histogram)."""
    from scipy import ndimage
    counts, xe, ye = np.histogram2d(x, y, bins=60, range=[xlim, ylim])
    if counts.sum() < 50:
        return
    dens = ndimage.gaussian_filter(counts, 2.0)
    flat = np.sort(dens.ravel())[::-1]
    cum = np.cumsum(flat) / flat.sum()
    levels = sorted({float(flat[min(np.searchsorted(cum, m), flat.size - 1)]) for m in CONTOUR_MASSES})
    if len(levels) == len(CONTOUR_MASSES) and levels[0] > 0:
        xc, yc = 0.5 * (xe[1:] + xe[:-1]), 0.5 * (ye[1:] + ye[:-1])
        ax.contour(xc, yc, dens.T, levels=levels, colors=["C0", "C0"], linewidths=[0.8, 1.4])


def _prior(result, name: str) -> Prior:
    """The prior of ``inertia`` or ``damping`` the analysis used (from its protocol)."""
    return getattr(result.protocol, f"{name}_prior")


def _hist(ax, x, interval, marks, label, inside, prior: Prior):
    """Histogram of draws ``x`` (n,) with the (median, lo, hi) interval, the prior's density and
    the marks inside the axis."""
    from matplotlib.ticker import NullLocator
    ax.hist(x, bins=40, color="C0", alpha=0.55, density=True, histtype="stepfilled", label="posterior")
    lo_x, hi_x = ax.get_xlim()
    ax.set_ylim(0, 1.25 * ax.get_ylim()[1])       # a prior far taller than the posterior is cut off
    grid_x = np.linspace(lo_x, hi_x, 200)
    density = prior_density(grid_x, prior)
    if density is None:
        ax.plot([], [], color="C2", lw=1.2, ls="--", label="prior: flat on > 0 (no density to draw)")
    else:
        ax.plot(grid_x, density, color="C2", lw=1.2, ls="--", label=f"prior: {_prior_text(prior)}")
    ax.set_xlim(lo_x, hi_x)
    med, lo, hi = interval
    ax.axvspan(lo, hi, color="C0", alpha=0.12, lw=0)
    ax.axvline(med, color="k", lw=1.2)
    for (name, value, marker, colour), ok in zip(marks, inside):
        if ok:
            ax.axvline(value, color=colour, lw=1, ls=":", label=name)
        elif value is not None and np.isfinite(value):
            right = value > hi_x
            ax.annotate(f"{name} {value:.4g} »" if right else f"« {name} {value:.4g}",
                        xy=(1.0 if right else 0.0, 0.55), xycoords="axes fraction", ha="right" if right else "left",
                        fontsize=FONT["small"], color=colour)
    ax.legend(loc="upper right", fontsize=FONT["small"], framealpha=0.85)
    ax.set_xlabel(label)
    ax.set_ylabel("probability density")
    ax.yaxis.set_major_locator(NullLocator())     # its values say nothing a reader needs; the shape does
    ax.grid(False)                                # the values are in the panel beside; lines here only clutter


class _Parameter(NamedTuple):
    """What the page shows of one of inertia and damping.

    Parameters
    ----------
    name, symbol, unit : str
        ``inertia``, ``m``, ``kg·m²`` (or damping, b, …).
    interval : Interval
        The posterior median and interval, SI units.
    draws : ndarray, shape (n,)
        The posterior draws, SI units.
    marks : list of (str, float or None, str, str)
        Least-squares and maximum-likelihood values: (label, value, marker, colour).
    free : bool
        False when the value was given (all draws equal).
    limits : (float, float) or None
        Axis range (None when not free).
    inside : list of bool
        Per mark, whether it lies inside ``limits``.
    """

    name: str
    symbol: str
    unit: str
    interval: Interval
    draws: np.ndarray
    marks: list
    free: bool
    limits: tuple | None
    inside: list

    @property
    def label(self) -> str:
        """Axis label: ``inertia m [kg·m²]``."""
        return f"{self.name} {self.symbol} [{self.unit}]"


def mechanics_page(result):
    """The posterior of inertia and damping as a pairwise plot (or why there is none)."""
    post = result.posterior
    fig = new_page("Inertia and damping: posterior")
    if post is None:
        _no_posterior(fig, result)
        return fig
    draws = np.asarray(post.draws, float)
    params = _parameters(result, draws)
    free = [p for p in params if p.free]
    outer = grid(fig, 2, 1, height_ratios=[2, 0.75], hspace=0.28)
    gs = outer[0].subgridspec(2, 2, hspace=0.3, wspace=0.3)
    diag = _diagonal(fig, gs, free, result)
    if not free and result.identification.effects and post.amplitudes.size:
        _amplitude(fig.add_subplot(gs[0, :]), post.amplitudes[:, 0], result.identification.effects[0])
    if len(free) == 2:
        _pair(fig.add_subplot(gs[1, 0], sharex=diag[0]), *params, result.ci_level)
        diag[0].set_xlabel("")
    text_panel(fig, gs[0, 1] if len(free) == 2 else gs[1, :], _value_rows(result, params, draws), title="Values", key_width=0.4, wrap=34,
               fontsize=FONT["small"])
    _noise_levels(fig.add_subplot(outer[1].subgridspec(1, 4)[0, 1:]), draws, result.trial.units)
    return fig


def _no_posterior(fig, result) -> None:
    """Say on the page ``fig`` why there is no posterior: direct variant, or m and b given."""
    u = result.trial.units
    if result.variant == "direct":
        why = ("Direct variant: the torque on the elastic element is measured, so the stiffness needs "
               "no inertia or damping and none was identified.")
    else:
        why = (f"Inertia and damping were given, not identified: m = {fmt(result.inertia.median, u['inertia'])}, "
               f"b = {fmt(result.damping.median, u['damping'])}. There is no posterior to show; the band "
               "of the stiffness holds the estimator's own uncertainty only.")
    text_panel(fig, (0.06, 0.5, 0.88, 0.38), why, title="No posterior of inertia and damping", wrap=80)


def _parameters(result, draws: np.ndarray) -> list[_Parameter]:
    """Inertia and damping as the page shows them, from the posterior draws (n, ≥ 2)."""
    ident = result.identification
    params = []
    for j, (name, symbol) in enumerate((("inertia", "m"), ("damping", "b"))):
        marks = [("least squares", getattr(ident.least_squares, name), "s", "C1"),
                 ("max. likelihood", getattr(ident.maximum_likelihood, name), "D", "C3")]
        free = bool(np.ptp(draws[:, j]) > 0)
        limits, inside = _limits(draws[:, j], [v for _, v, _, _ in marks]) if free else (None, [True, True])
        params.append(_Parameter(name, symbol, result.trial.units[name], getattr(result, name), draws[:, j],
                                 marks, free, limits, inside))
    return params


def _amplitude(ax, draws: np.ndarray, effect) -> None:
    """Histogram of an effect's amplitude (m and b given: the only coefficients fitted), with its interval."""
    from matplotlib.ticker import NullLocator
    iv = effect.amplitude
    ax.hist(draws, bins=40, color="C0", alpha=0.55, density=True, histtype="stepfilled", label="posterior")
    ax.axvspan(iv.lo, iv.hi, color="C0", alpha=0.12, lw=0)
    ax.axvline(iv.median, color="k", lw=1.2)
    ax.legend(loc="upper right", fontsize=FONT["small"], framealpha=0.85)
    ax.set_xlabel(f"{effect.name} {effect.amplitude_name} [{effect.unit}] (in the model; m and b given)")
    ax.set_ylabel("probability density")
    ax.yaxis.set_major_locator(NullLocator())
    ax.grid(False)


def _diagonal(fig, gs, free: list[_Parameter], result) -> list:
    """Histograms of the free parameters: the diagonal of the 2×2 grid ``gs`` (or its top row)."""
    from matplotlib.ticker import MaxNLocator
    axes = []
    for k, p in enumerate(free):
        ax = fig.add_subplot(gs[k, k] if len(free) == 2 else gs[0, :])
        iv = p.interval
        ax.set_xlim(*p.limits)
        _hist(ax, p.draws, (iv.median, iv.lo, iv.hi), p.marks, p.label, p.inside, _prior(result, p.name))
        ax.xaxis.set_major_locator(MaxNLocator(4))
        axes.append(ax)
    return axes


def _pair(ax, m: _Parameter, b: _Parameter, ci: float) -> None:
    """The (m, b) draws on ``ax``: points, contours, median with intervals, point estimates."""
    from matplotlib.ticker import MaxNLocator
    ax.scatter(m.draws, b.draws, s=2, lw=0, color="C0", alpha=0.35, rasterized=True, label="posterior draws")
    _contours(ax, m.draws, b.draws, m.limits, b.limits)
    mi, bi = m.interval, b.interval
    ax.errorbar([mi.median], [bi.median], xerr=[[mi.median - mi.lo], [mi.hi - mi.median]],
                yerr=[[bi.median - bi.lo], [bi.hi - bi.median]], fmt="o", color="k", ms=5, capsize=3, lw=1,
                label=f"median, {100 * ci:.0f} % intervals")
    for (name, vm, marker, colour), (_, vb, _, _), okm, okb in zip(m.marks, b.marks, m.inside, b.inside):
        if okm and okb:
            ax.plot([vm], [vb], marker, color=colour, ms=7, mfc="none", mew=1.5, label=name)
    ax.set_xlim(*m.limits)
    ax.set_ylim(*b.limits)
    ax.yaxis.set_major_locator(MaxNLocator(5))
    ax.set_xlabel(m.label)
    ax.set_ylabel(b.label)
    ax.legend(loc="upper right", fontsize=FONT["small"], framealpha=0.85)


def _value_rows(result, params: list[_Parameter], draws: np.ndarray) -> list[tuple[str, str]]:
    """(key, value) rows of the page's table: intervals, point estimates, priors, correlation."""
    rows = []
    for p in params:
        iv = p.interval
        if p.free:
            rows.append((f"{p.name} {p.symbol}", f"{fmt(iv.median, p.unit)} [{fmt(iv.lo)}, {fmt(iv.hi)}]"))
        else:
            rows.append((f"{p.name} {p.symbol}", f"{fmt(iv.median, p.unit)} (given)"))
        for (what, v, _, _), ok in zip(p.marks, p.inside):
            if v is not None:
                rows.append((f"  {what}", fmt(v, p.unit) + ("" if ok else " (off the plot)")))
        rows.append(("  prior", _prior_text(_prior(result, p.name))))
    if all(p.free for p in params):
        rows.append(("correlation", f"{np.corrcoef(draws[:, 0], draws[:, 1])[0, 1]:+.2f}"))
    rows += _effect_rows(result.identification.effects)
    rows.append(("draws", f"{draws.shape[0]}; black: median, shaded: {100 * result.ci_level:.0f} % interval; "
                          "contours hold 50 % and 90 % of the draws"))
    return rows


def _noise_levels(ax, draws, u) -> None:
    """The posterior of the log noise levels (ln R, ln Q_s, ln Q_σ, ln Q_c) on one axes: each a
    row, its draws' histogram about their median (the levels differ by orders of magnitude, their
    spreads do not)."""
    unit = NoiseLevels.units(u["torque"], u["stiffness"])
    names = [f"measurement noise R [{unit['measurement']}]", f"elastic-torque walk Q_s [{unit['torque_walk']}]",
             f"stiffness walk, free Q_sigma [{unit['stiffness_walk']}]",
             f"stiffness walk, coupled Q_c [{unit['coupled_walk']}]"]
    labels = []
    for k in range(min(4, draws.shape[1] - 2)):
        x = draws[:, 2 + k]
        x = x[np.isfinite(x)]
        if x.size == 0:
            labels.append(f"{names[k]}: no draws")
            continue
        med = float(np.median(x))
        counts, edges = np.histogram(x - med, bins=30)
        top = k + 0.4 * counts / max(counts.max(), 1)
        ax.fill_between(np.repeat(edges, 2)[1:-1], k - 0.4 * counts.repeat(2) / max(counts.max(), 1),
                        top.repeat(2), color="0.5", alpha=0.7, lw=0)
        labels.append(f"{names[k]}\nln median {med:.3g}")
    ax.axvline(0, color="k", lw=1)
    ax.set_yticks(range(len(labels)), labels, fontsize=FONT["small"])
    ax.set_ylim(-0.6, len(labels) - 0.4)
    ax.invert_yaxis()
    ax.set_xlabel("ln level - its posterior median (0.69 = a factor of 2)")
    ax.set_title("Posterior of the Kalman model's noise levels", fontsize=FONT["body"], loc="left")


def _effect_rows(effects) -> list[tuple[str, str]]:
    """The effects put in the model (``--effect``): amplitude with its interval, and shape."""
    rows = []
    for e in effects:
        iv = e.amplitude
        rows.append((f"{e.name} {e.amplitude_name}", f"{fmt(iv.median, e.unit)} [{fmt(iv.lo)}, {fmt(iv.hi)}] "
                                                     "(in the model)"))
        rows.append(("  shape", shape_text(e.shape) or "none"))
    return rows
