"""A batch's trials drawn into an axes of one's own: :meth:`limbstiff.batch.outcome.BatchReport.plot`."""

from __future__ import annotations

import numpy as np


def plot_trials(names, median, lo, hi, *, ax=None, label: str = "stiffness"):
    """Draw one figure per trial, its median as a point and its interval as a line, a row each.

    Parameters
    ----------
    names : sequence of str, length T
        The trials, top to bottom.
    median, lo, hi : array_like, shape (T,)
        The figure and its interval's bounds (NaN: not available, nothing drawn).
    ax : matplotlib.axes.Axes, optional
        Where to draw; pyplot's current axes when omitted.
    label : str
        The x axis's label (the figure with its unit).

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    median, lo, hi = (np.asarray(x, dtype=float) for x in (median, lo, hi))
    y = np.arange(len(names))[::-1]
    ax.hlines(y, lo, hi, color="C0", lw=1.2)
    ax.plot(median, y, "o", color="C0", ms=4)
    ax.set_yticks(y, list(names))
    ax.set_xlabel(label)
    return ax
