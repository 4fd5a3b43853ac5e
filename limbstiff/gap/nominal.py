"""The nominal model, its residual and the size of the gap.

The nominal model is the one the stiffness analysis used — the paper's eq. (6),
f = m·ÿ + b·ẏ + s(y, t) — simulated from the measured angle: the torque it predicts is
compared with the measured torque. m and b are those the analysis used (given or identified);
the elastic torque s is the nuisance. Within each *window* of a few motion periods it is a
local spring, cubic in the angle, whose stiffness may drift linearly in time,

    s(y, t) ≈ c_w + k_w·Δ + q_w·Δ² + c3_w·Δ³ + k′_w·(t − t̄_w)·Δ,     Δ = y − ȳ_w,

refitted on whatever data are scored. This is the tool's own model at the time scale its
stiffness estimate resolves (bound (9) of the paper: a stiffness is only observable when it
changes slowly compared with the motion). Integrating the tool's stiffness course instead
(s = ∫σ̂ dy) was measured to fail as a nuisance: with an unmodelled effect present the Kalman
noise fit degenerates (on the simulated ankle with hysteresis the stiffness walk reaches its
upper bound and σ̂ follows every sample), so ∫σ̂ dy absorbs part of the effect and distorts the
rest. A per-window free offset absorbs any torque slower than a window, so drift slower than a
window is indistinguishable from a slow change of the elastic equilibrium (tonic torque), which
the tool's model allows. Any torque that depends on the angle alone is a (generalized)
stiffness — the paper's own example has k = α(u_b + u_t) − mgl·cos θ — so gravity is absorbed
by the elastic term by construction. The quadratic and cubic terms are needed on real encoders:
on the simulated elbow (8000 counts) the quantisation error of the slowly moving angle near
reversals leaves, through errors in variables, a residual odd in the angle that a linear spring
cannot take up (a −mgl·sin y term with mgl = 270 N·m "explained" 21 % of the clean trial's gap).

Rows: the diagnosis fits on the filtered signals decimated to about 2.5× the low-pass corner
(the Kalman smoother's step: above the Nyquist rate of the filtered band, so neighbouring rows
carry nearly independent noise). Windows are cut into *units* of about one motion period,
the pieces whose held-out gains the significance test compares. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..estimate.observer import informed_samples
from .channels import Channels

#: Motion periods per nuisance window: the identification's local-linear elastic window
#: (``analysis.IDENTIFY_PERIODS``), long enough to fit a spring, short enough for it to be local.
WINDOW_PERIODS = 4.0
#: Scoring units per window (one per motion period).
UNITS_PER_WINDOW = 4
#: Fewest rows in a unit.
MIN_UNIT_ROWS = 8
#: Filtered steps per low-pass corner period (as ``estimators.KALMAN_STEPS_PER_CORNER_PERIOD``).
STEPS_PER_CORNER_PERIOD = 1.25
#: Samples at each end kept out besides the filter edge: the longest look-back of a candidate
#: (reflex delays up to 80 ms) and the largest channel shift (50 ms).
LOOKBACK_S = 0.08
#: Fewest held-out blocks (windows) a single trial must hold.
MIN_BLOCKS = 3
#: Names of the elastic nuisance columns of a window.
NUISANCE = ("offset", "stiffness", "quadratic", "cubic", "stiffness_drift")

METRIC = ("variance not accounted for: sum of squared residuals over the sum of squared deviations "
          "of the measured torque from its mean, both low-passed like the analysis (a fraction; "
          "1 − VAF)")


def effective_cutoff(ch: Channels) -> float:
    """Corner of the filter chain, Hz (the paper chain's prefilter 1/(2πτ); Nyquist when unfiltered)."""
    if ch.chain.kind == "paper":
        return 1.0 / (2 * np.pi * ch.chain.prefilter_time_constant)
    return ch.cutoff_hz if ch.cutoff_hz is not None else 0.5 * ch.fs


@dataclass(frozen=True)
class Layout:
    """Which samples of one trial are fitted and how they are grouped.

    Parameters
    ----------
    trial : str
    rows : ndarray of int, shape (r,)
        Full-rate sample indices used.
    window, unit, segment : ndarray of int, shape (r,)
        Window, unit (numbered within the trial) and segment (held-out block, 0 when the whole
        trial is one fold) of each row; windows never straddle segments.
    decimation : int
        Samples per row.
    window_s, unit_s : float
        Lengths in seconds.
    """

    trial: str
    rows: np.ndarray
    window: np.ndarray
    unit: np.ndarray
    segment: np.ndarray
    decimation: int
    window_s: float
    unit_s: float

    @property
    def n_units(self) -> int:
        return int(self.unit.max()) + 1

    @property
    def n_segments(self) -> int:
        return int(self.segment.max()) + 1


def layout(ch: Channels, *, blocks: int = 1, decimation: int | None = None) -> Layout:
    """Rows, windows, units and held-out blocks of one trial.

    Parameters
    ----------
    ch : Channels
    blocks : int
        Contiguous held-out blocks (segments) of whole windows, at most one per window (and at
        least :data:`MIN_BLOCKS`); 1 when the trial is one fold.
    decimation : int, optional
        Samples per row; default :data:`STEPS_PER_CORNER_PERIOD` rows per corner period.

    Returns
    -------
    Layout

    Raises
    ------
    ValueError
        When the trial holds fewer windows than ``blocks`` (too short to diagnose).
    """
    if decimation is None:
        decimation = max(1, int(ch.fs / (2 * STEPS_PER_CORNER_PERIOD * effective_cutoff(ch))))
    margin = ch.edge + int(np.ceil(LOOKBACK_S * ch.fs))
    rows = np.arange(margin, ch.n - margin, decimation)
    row_s = decimation / ch.fs
    unit_rows = max(MIN_UNIT_ROWS, int(round(1.0 / (ch.motion_hz * row_s))))
    win_rows = UNITS_PER_WINDOW * unit_rows
    n_win = int(round(len(rows) / win_rows))
    need = 1 if blocks <= 1 else MIN_BLOCKS
    if n_win < need:
        raise ValueError(f"{ch.name}: too short to diagnose: {len(rows) * row_s:.1f} s hold {n_win} window(s) of "
                         f"{win_rows * row_s:.2f} s (4 motion periods), at least {need} are needed")
    blocks = min(blocks, n_win)
    window = np.empty(len(rows), dtype=int)
    for w, part in enumerate(np.array_split(np.arange(len(rows)), n_win)):
        window[part] = w
    unit = np.empty(len(rows), dtype=int)
    u = 0
    for w in range(n_win):
        idx = np.flatnonzero(window == w)
        for part in np.array_split(idx, UNITS_PER_WINDOW):
            unit[part] = u
            u += 1
    segment = np.zeros(len(rows), dtype=int)
    for s, ws in enumerate(np.array_split(np.arange(n_win), max(blocks, 1))):
        segment[np.isin(window, ws)] = s
    return Layout(trial=ch.name, rows=rows, window=window, unit=unit, segment=segment,
                  decimation=decimation, window_s=win_rows * row_s, unit_s=unit_rows * row_s)


def nuisance_columns(angle: np.ndarray, time: np.ndarray, window: np.ndarray) -> list[np.ndarray]:
    """The elastic nuisance of each window (see the module docstring).

    Parameters
    ----------
    angle, time : ndarray, shape (r,)
        y (rad) and t (s) at the rows.
    window : ndarray of int, shape (r,)
        Window of each row; rows of one window are contiguous.

    Returns
    -------
    list of ndarray, one (r_w, 5) block per window, in window order (columns :data:`NUISANCE`)
    """
    blocks = []
    for w in np.unique(window):
        sel = window == w
        y, t = angle[sel], time[sel]
        dy = y - y.mean()
        scale = max(float(np.std(dy)), 1e-300)
        u = dy / scale
        dt = (t - t.mean()) / max(np.ptp(t), 1e-12)
        blocks.append(np.column_stack([np.ones_like(y), u, u * u, u ** 3, dt * u]))
    return blocks


def _basis(matrix: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space (rank-revealing SVD)."""
    if matrix.shape[1] == 0:
        return matrix
    u, s, _ = np.linalg.svd(matrix, full_matrices=False)
    keep = s > 1e-9 * max(s[0], 1e-300)
    return u[:, keep]


@dataclass(frozen=True)
class Projector:
    """Removes the nuisance, refitted separately in every window (and segment), from columns.

    Built by :func:`projector`; ``project(M)`` returns M minus its least-squares fit on the
    nuisance columns of each window (plus any local columns, fitted per segment).
    """

    pieces: tuple          # (row index array, orthonormal basis) per window or segment

    def project(self, matrix: np.ndarray) -> np.ndarray:
        m = np.asarray(matrix, dtype=float)
        out = m.copy()
        for idx, q in self.pieces:
            block = m[idx]
            out[idx] = block - q @ (q.T @ block)
        return out


def projector(angle: np.ndarray, time: np.ndarray, lay: Layout, local: np.ndarray | None = None) -> Projector:
    """The nuisance projector of one trial's rows.

    Parameters
    ----------
    angle, time : ndarray, shape (r,)
        y and t at the rows.
    lay : Layout
    local : ndarray, shape (r, k), optional
        More nuisance columns fitted freely per segment (an accepted sensor drift).

    Returns
    -------
    Projector
    """
    blocks = nuisance_columns(angle, time, lay.window)
    starts = {w: np.flatnonzero(lay.window == w) for w in np.unique(lay.window)}
    pieces = []
    if local is None or local.shape[1] == 0:
        for (w, idx), block in zip(starts.items(), blocks):
            pieces.append((idx, _basis(block)))
        return Projector(tuple(pieces))
    for s in range(lay.n_segments):
        idx = np.flatnonzero(lay.segment == s)
        wins = np.unique(lay.window[idx])
        p = len(NUISANCE)
        cols = np.zeros((len(idx), p * len(wins)))
        for j, w in enumerate(wins):
            sel = lay.window[idx] == w
            cols[sel, p * j:p * j + p] = blocks[int(w)]
        loc = local[idx]
        loc = loc[:, np.any(np.abs(loc) > 0, axis=0)]
        pieces.append((idx, _basis(np.column_stack([cols, loc]))))
    return Projector(tuple(pieces))


def torque_deviation(ch: Channels, lay: Layout) -> np.ndarray:
    """f − f̄ at the rows: the denominator of the gap (N·m), shape (r,)."""
    f = ch.torque[lay.rows]
    return f - f.mean()


def gap(residual: np.ndarray, deviation: np.ndarray) -> float:
    """Variance not accounted for: Σ r² / Σ (f − f̄)² (a fraction)."""
    den = float(np.sum(deviation ** 2))
    return float(np.sum(residual ** 2) / den) if den > 0 else float("nan")


def filter_power(freq: np.ndarray, ch: Channels) -> np.ndarray:
    """|H(f)|² of the chain the channels went through (zero-phase Butterworth of order 4 run
    twice, or the paper's prefilter 1/(τs + 1)²)."""
    if ch.chain.kind == "paper":
        w = 2 * np.pi * freq * ch.chain.prefilter_time_constant
        return 1.0 / (1.0 + w ** 2) ** 2
    if ch.cutoff_hz is None:
        return np.ones_like(freq)
    return 1.0 / (1.0 + (freq / ch.cutoff_hz) ** 8) ** 2


def noise_floor(ch: Channels, lay: Layout) -> float:
    """Gap that white sensor noise alone would leave, as a fraction of the torque variance.

    The recorded spectral floors of torque (N_f) and angle (N_y) are taken as white and carried
    through the filter and the model, f − m·ÿ − b·ẏ − k·y, with k the median estimated
    stiffness: floor = ∫|H|²·(N_f + |k − m·ω² + i·b·ω|²·N_y) df, less the share the per-window
    nuisance fits (5 columns per window). Quantisation of a slowly moving angle is not white
    (its in-band level exceeds the floor), so this is a lower bound.
    """
    freq = np.linspace(0.0, 0.5 * ch.fs, 4097)
    k = float(np.median(ch.stiffness[informed_samples(ch.observable)]))
    w = 2 * np.pi * freq
    z2 = (k - ch.inertia * w ** 2) ** 2 + (ch.damping * w) ** 2
    power = np.trapezoid(filter_power(freq, ch) * (ch.torque_floor + z2 * ch.angle_floor), freq)
    rows_per_window = len(lay.rows) / (int(lay.window.max()) + 1)
    power *= max(0.0, 1.0 - len(NUISANCE) / rows_per_window)
    var = float(np.mean(torque_deviation(ch, lay) ** 2))
    return float(power / var) if var > 0 else float("nan")
