"""The ticks of a report's axes: fewer on a page-wide axis, and fixed once a page is built.

Every tick is five artists (two marks, a grid line, two labels) made and drawn one by one, and
matplotlib locates and formats an axis's ticks again each time it needs their size: ticks are
most of a report's artists and of its drawing (profiled).
"""

from __future__ import annotations

import numpy as np


#: Most intervals between labelled ticks on a linear axis (matplotlib's default allows up to 9 on a
#: page-wide axis).
TICK_BINS = 5


def lean_ticks(fig) -> None:
    """At most :data:`TICK_BINS` tick intervals on every linear axis of ``fig`` whose ticks were
    left to matplotlib (axes that set their own locator keep it), then every axis's ticks fixed
    (:func:`fix_ticks`): call it once the page is built, its limits final."""
    from matplotlib.ticker import AutoLocator, MaxNLocator
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "linear" and type(axis.get_major_locator()) is AutoLocator:
                axis.set_major_locator(MaxNLocator(nbins=TICK_BINS, steps=[1, 2, 2.5, 5, 10]))
            fix_ticks(axis)


def fix_ticks(axis) -> None:
    """Fix an axis's major ticks to those its locator and formatter give now, within its limits.

    Located and formatted once, not three times as a page is drawn; and no tick is made for a
    location beyond a limit (a locator gives one beyond each, never drawn). The labels are the
    formatter's over all the locations, as matplotlib formats them; an axis whose labels carry
    an offset or a common power of ten (drawn apart, at the axis's end) is left as it is.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        Of an axes whose limits are final.
    """
    from matplotlib.ticker import FixedFormatter, FixedLocator
    locs = np.asarray(axis.get_majorticklocs(), float)
    if locs.size == 0:
        return
    formatter = axis.get_major_formatter()
    labels = formatter.format_ticks(locs)
    if formatter.get_offset():
        return
    # the ticks matplotlib draws: within the limits, to a tolerance, on the scale's transform
    transform = axis.get_transform()
    ends = np.sort(transform.transform(np.asarray(axis.get_view_interval(), float)))
    at = transform.transform(locs)
    slack = 1e-9 * (ends[1] - ends[0])
    keep = np.flatnonzero((at >= ends[0] - slack) & (at <= ends[1] + slack))
    axis.set_major_locator(FixedLocator(locs[keep]))
    axis.set_major_formatter(FixedFormatter([labels[k] for k in keep]))
