"""Least-squares inertia and damping, with a windowed local-linear elastic term.

The model of a recording is f = m·ÿ + b·ẏ + s(y, t): m and b constant over the trial, the
elastic torque s free to vary in time with no assumed form. Over a window short enough for s
to be locally linear, s ≈ k_w·y + c_w; with one (k_w, c_w) per window, m and b follow by
linear least squares after projecting the window terms out (Frisch–Waugh–Lovell), so the
cost is one pass over the data whatever the number of windows.

Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LeastSquaresFit:
    """Point estimate of inertia and damping.

    Parameters
    ----------
    inertia : float, kg·m² (kg)
    damping : float, N·m·s/rad (N·s/m)
    inertia_se, damping_se : float
        Standard errors from the residual variance (white-noise assumption: a lower bound).
    window : float, s
        Length of the windows over which the elastic term was taken as linear in y.
    residual_sd : float, N·m (N)
        Standard deviation of the torque residual.
    condition : float
        Condition number of the (scaled) regressors: large means m and b cannot be told apart
        from the elastic term with this motion (for example a single sinusoid).
    """

    inertia: float
    damping: float
    inertia_se: float
    damping_se: float
    window: float
    residual_sd: float
    condition: float


def _project_out_windows(columns: np.ndarray, angle: np.ndarray, length: int) -> np.ndarray:
    """Residuals of each column after regression on [1, y] within consecutive windows."""
    n = angle.size
    n_win = max(1, n // length)
    edges = np.linspace(0, n, n_win + 1).astype(int)
    out = np.empty_like(columns)
    for lo, hi in zip(edges[:-1], edges[1:]):
        y = angle[lo:hi] - angle[lo:hi].mean()
        block = columns[:, lo:hi] - columns[:, lo:hi].mean(axis=1, keepdims=True)
        yy = y @ y
        slope = block @ y / yy if yy > 0 else np.zeros(len(columns))
        out[:, lo:hi] = block - slope[:, None] * y
    return out


def least_squares(torque: np.ndarray, angle: np.ndarray, velocity: np.ndarray,
                  acceleration: np.ndarray, *, sample_period: float, window: float) -> LeastSquaresFit:
    """Least-squares inertia and damping with a windowed local-linear elastic term.

    Parameters
    ----------
    torque : ndarray, shape (n,), N·m (N)
        External torque f (filtered like the angle).
    angle, velocity, acceleration : ndarray, shape (n,), rad, rad/s, rad/s² (m, m/s, m/s²)
    sample_period : float, s
    window : float, s
        Length of the windows with one linear elastic term each.

    Returns
    -------
    LeastSquaresFit
    """
    length = max(8, int(round(window / sample_period)))
    cols = _project_out_windows(np.vstack([torque, acceleration, velocity]), angle, length)
    f, x = cols[0], cols[1:].T
    scale = np.sqrt(np.sum(x * x, axis=0))
    scale[scale == 0] = 1.0
    xs = x / scale
    coef, *_ = np.linalg.lstsq(xs, f, rcond=None)
    resid = f - xs @ coef
    n_win = max(1, angle.size // length)
    dof = max(1, angle.size - 2 - 2 * n_win)
    s2 = float(resid @ resid) / dof
    cov = s2 * np.linalg.pinv(xs.T @ xs)
    coef = coef / scale
    se = np.sqrt(np.diag(cov)) / scale
    return LeastSquaresFit(inertia=float(coef[0]), damping=float(coef[1]), inertia_se=float(se[0]),
                           damping_se=float(se[1]), window=length * sample_period,
                           residual_sd=float(np.sqrt(s2)), condition=float(np.linalg.cond(xs)))
