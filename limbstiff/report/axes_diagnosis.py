"""The diagnosis drawn into an axes of one's own: :meth:`limbstiff.diagnosis.result.Diagnosis.plot`."""

from __future__ import annotations

import numpy as np


def plot_candidates(diagnosis, *, ax=None):
    """Draw each candidate effect tried: the share of the nominal model's held-out gap it removes,
    with its bootstrap interval (red: chosen, orange: significant and relevant, grey: neither).

    Parameters
    ----------
    diagnosis : Diagnosis
    ax : matplotlib.axes.Axes, optional
        Where to draw; pyplot's current axes when omitted.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    tried = [c for c in diagnosis.candidates if c.evidence.tried]
    ypos = np.arange(len(tried))[::-1]
    for y, c in zip(ypos, tried):
        judged = c.evidence.significant and c.evidence.relevant
        color = "C3" if c.effect in diagnosis.diagnosis else ("C1" if judged else "0.6")
        lo, hi = c.shrink_interval
        ax.barh(y, 100 * c.shrink_heldout, color=color, alpha=0.8)
        ax.plot([100 * lo, 100 * hi], [y, y], color="k", lw=1)
    ax.set_yticks(ypos, [c.effect for c in tried])
    ax.axvline(0, color="k", lw=0.6)
    ax.set_xlabel(f"held-out gap removed (%; line: {100 * diagnosis.settings.ci_level:.0f} % bootstrap interval)")
    return ax
