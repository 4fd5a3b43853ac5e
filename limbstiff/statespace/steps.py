"""The data of the state-space model at its steps: one definition for every user.

The model (:mod:`limbstiff.statespace`) runs on every ``decimation``-th sample of the filtered
signals. At those steps it needs the angle's increments, the spring's deflection, the
measurement channels — z itself, or the torque with the columns whose coefficients enter z
linearly (ÿ and ẏ for m and b, an effect's torque, a stiffness basis) — each channel's initial
stiffness slope, the diffuse initial covariance and where the filter restarts. :class:`ModelSteps`
holds them; the builders below make it for the estimator (:func:`model_steps`), for the
identification of m and b (:func:`mechanics_steps`) and for any set of channels
(:func:`channel_steps`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

#: Kalman steps per period of the low-pass corner: 1.25 puts the step rate at 2.5× the corner,
#: just above the Nyquist rate of the filtered band, so that the filtered noise is close to
#: white from step to step as the model assumes. Finer steps let correlated residuals (a
#: stretch reflex, filtered noise) pass for stiffness changes: on the real ankle data, steps of
#: 1 ms drove the noise fit to a degenerate optimum (R → 0), and in the simulated benchmark 1.25
#: and 2 gave the same accuracy while 4 and above lost it.
KALMAN_STEPS_PER_CORNER_PERIOD = 1.25
#: Motion periods of the moving average the deflection is taken from (:func:`deflection`).
DEFLECTION_PERIODS = 4.0
#: Windows the trial is cut into for the local stiffness scale (:func:`initial_cov`).
SCALE_WINDOWS = 16
#: Most filter steps used to identify m, b and the noise levels, and in how many blocks.
MAX_IDENTIFY_STEPS, IDENTIFY_BLOCKS = 6000, 6


def kalman_decimation(sample_period: float, cutoff_hz: float | None) -> int:
    """Samples per Kalman step: :data:`KALMAN_STEPS_PER_CORNER_PERIOD` steps per corner period
    (every sample when the signals are not low-passed)."""
    if cutoff_hz is None:
        return 1
    return max(1, int(1.0 / (sample_period * KALMAN_STEPS_PER_CORNER_PERIOD * 2 * cutoff_hz)))


def step_index(samples: int, *, edge: int, decimation: int) -> np.ndarray:
    """The sample of each filter step: every ``decimation``-th from ``edge`` to ``samples − edge``
    (shape (m,)); the trial-level figures use the same steps, whatever the estimator."""
    return np.arange(edge, samples - edge, decimation)


def deflection(angle: np.ndarray, *, step: float, motion_frequency: float) -> np.ndarray:
    """The part of the spring's deflection that follows the motion: the angle less its moving
    average over :data:`DEFLECTION_PERIODS` motion periods (rad, shape (n,)). The rest angle is
    not known; what the average leaves out is slow and goes to the torque walk Q_s."""
    from scipy.ndimage import uniform_filter1d

    y = np.asarray(angle, dtype=float)
    window = int(round(DEFLECTION_PERIODS / (motion_frequency * step))) if motion_frequency else len(y)
    window = min(max(window, 1), max(len(y), 1))
    return np.ascontiguousarray(y - uniform_filter1d(y, window, mode="nearest"))


def initial_slopes(angle: np.ndarray, channels: np.ndarray) -> np.ndarray:
    """The least-squares slope on y of each channel (c, n) over the first tenth (at least 8
    samples): the initial σ of a filter pass over that channel, linear in it. Shape (c,)."""
    n0 = max(8, len(angle) // 10)
    yc = angle[:n0] - angle[:n0].mean()
    yy = float(yc @ yc) or 1.0          # a still start: yc = 0, so every slope is 0
    head = np.atleast_2d(channels)[:, :n0]
    return (head - head.mean(axis=1, keepdims=True)) @ yc / yy


def initial_cov(angle, scale_from) -> tuple[float, float, float]:
    """Diffuse initial covariance [p11, p12, p22] from the size of a torque signal (not of z, so
    that it does not change with m and b): var(torque) for s; for σ the square of the larger of
    the secant stiffness sd(torque)/sd(y) and the steepest local one, the torque's least-squares
    slope on y in :data:`SCALE_WINDOWS` windows that move (at least a tenth of the median
    window's spread).

    σ's variance also sets the scale of the stiffness walk's bounds
    (:func:`~limbstiff.statespace.noise.noise_bounds`). The secant alone understates a spring
    that stiffens with the angle: on the paper's exponential spring its tangent stiffness
    reaches several times the secant one, the walk sat on its bound and the estimate was 75 %
    off."""
    y, f = np.asarray(angle, dtype=float), np.asarray(scale_from, dtype=float)
    v = float(np.var(f)) + 1e-300
    k2 = v / max(float(np.var(y)), 1e-300)
    size = len(y) // SCALE_WINDOWS
    if size >= 8:
        yw = y[:size * SCALE_WINDOWS].reshape(SCALE_WINDOWS, size)
        fw = f[:size * SCALE_WINDOWS].reshape(SCALE_WINDOWS, size)
        yc, fc = yw - yw.mean(axis=1, keepdims=True), fw - fw.mean(axis=1, keepdims=True)
        yy = np.sum(yc * yc, axis=1)
        moving = yy >= 0.01 * np.median(yy)
        if np.any(moving) and np.median(yy) > 0:
            k2 = max(k2, float(np.max((np.sum(yc * fc, axis=1)[moving] / yy[moving]) ** 2)))
    return (v, 0.0, k2)


@dataclass(frozen=True)
class ModelSteps:
    """The data of the state-space model at its steps.

    Parameters
    ----------
    index : ndarray of int, shape (m,)
        Sample of each step.
    angle : ndarray, shape (m,), rad (m)
        y at the steps.
    channels : ndarray, shape (c, m)
        The measurement channels: row 0 is z (or the torque whose linear coefficients are
        fitted), rows 1… the columns whose coefficients enter z linearly (N·m per unit
        coefficient). The filter is linear in the data, so one pass serves them all.
    slopes : ndarray, shape (c,)
        Each channel's initial stiffness (:func:`initial_slopes`): the filter's initial σ.
    increments : ndarray, shape (m,), rad (m)
        y[k] − y[k−1] (the first 0, or ignored).
    deflection : ndarray, shape (m,), rad (m)
        The spring's deflection g (:func:`deflection`).
    initial_cov : (float, float, float)
        Diffuse initial covariance [p11, p12, p22] (:func:`initial_cov`).
    step : float, s
        Time between steps.
    restart : ndarray of bool, shape (m,)
        Where the filter restarts (independent blocks of data); all False for one record.
    """

    index: np.ndarray
    angle: np.ndarray
    channels: np.ndarray
    slopes: np.ndarray
    increments: np.ndarray
    deflection: np.ndarray
    initial_cov: tuple
    step: float
    restart: np.ndarray

    @property
    def measured(self) -> np.ndarray:
        """z at the steps (channel 0), N·m (N)."""
        return self.channels[0]

    @property
    def initial_mean(self) -> tuple[float, float]:
        """[s0, σ0] of channel 0: its first value and its initial slope. Linear in the channel,
        so that the smoother's mean stays linear in z."""
        return float(self.channels[0, 0]), float(self.slopes[0])

    def with_channels(self, extra: np.ndarray) -> "ModelSteps":
        """The same steps with the rows ``extra`` (k, m) appended to the channels (their own
        initial slopes computed), for a pass that fits their coefficients too."""
        extra = np.atleast_2d(np.asarray(extra, dtype=float))
        return replace(self, channels=np.ascontiguousarray(np.vstack([self.channels, extra])),
                       slopes=np.concatenate([self.slopes, initial_slopes(self.angle, extra)]))


def _increments(y: np.ndarray) -> np.ndarray:
    return np.diff(y, prepend=y[0])


def model_steps(angle: np.ndarray, measured: np.ndarray, *, sample_period: float, decimation: int, edge: int,
                motion_frequency: float, scale_from: np.ndarray | None = None) -> ModelSteps:
    """Every ``decimation``-th sample between the ``edge`` samples at each end, with z as the one
    channel (arguments as :func:`limbstiff.estimate.kalman.kalman_stiffness`)."""
    idx = step_index(len(angle), edge=edge, decimation=decimation)
    y, z = angle[idx], measured[idx]
    step = sample_period * decimation
    return ModelSteps(index=idx, angle=y, channels=np.ascontiguousarray(z, dtype=float)[None, :],
                      slopes=np.array([float(initial_slopes(y, z)[0])]), increments=_increments(y),
                      deflection=deflection(y, step=step, motion_frequency=motion_frequency),
                      initial_cov=initial_cov(y, z if scale_from is None else np.asarray(scale_from)[idx]),
                      step=step, restart=np.zeros(len(idx), dtype=bool))


def mechanics_steps(angle, velocity, acceleration, torque, *, sample_period: float, decimation: int,
                    motion_frequency: float, edge: int = 0, extra: np.ndarray | None = None,
                    with_mechanics: bool = True, scale_from: np.ndarray | None = None) -> ModelSteps:
    """The steps with the channels (f, ÿ, ẏ), whose likelihood is a quadratic form in (1, −m, −b).

    ``extra`` (k, n) appends channels whose coefficients are fitted too (an effect's torque per
    unit amplitude); without ``with_mechanics`` the channels are (``torque``, extra…): m and b are
    given and ``torque`` is already z = f − m·ÿ − b·ẏ (``scale_from``, default ``torque``, is the
    recorded torque whose size sets the diffuse start).

    Long trials are taken on at most :data:`MAX_IDENTIFY_STEPS` filter steps, as
    :data:`IDENTIFY_BLOCKS` equal blocks spread over the trial (the filter restarts at each): m
    and b are constant, so a few thousand steps pin them down, and the cost of identifying them
    stops growing with the trial's length.
    """
    idx = np.arange(edge, len(angle) - edge, decimation)
    step = sample_period * decimation
    g = deflection(angle[idx], step=step, motion_frequency=motion_frequency)
    restart = np.zeros(len(idx), dtype=bool)
    if len(idx) > MAX_IDENTIFY_STEPS:
        size = MAX_IDENTIFY_STEPS // IDENTIFY_BLOCKS
        starts = np.linspace(0, len(idx) - size, IDENTIFY_BLOCKS).astype(int)
        kept = np.concatenate([np.arange(s0, s0 + size) for s0 in starts])
        idx, g = idx[kept], np.ascontiguousarray(g[kept])
        restart = np.zeros(len(idx), dtype=bool)
        restart[::size] = True
    y = np.ascontiguousarray(angle[idx], dtype=float)
    rows = [torque[idx]] + ([acceleration[idx], velocity[idx]] if with_mechanics else [])
    if extra is not None:
        rows += list(np.atleast_2d(extra)[:, idx])
    chans = np.ascontiguousarray(np.vstack(rows), dtype=float)
    scale = chans[0] if scale_from is None else np.asarray(scale_from, dtype=float)[idx]
    return ModelSteps(index=idx, angle=y, channels=chans, slopes=initial_slopes(y, chans), increments=_increments(y),
                      deflection=g, initial_cov=initial_cov(y, scale), step=step, restart=restart)


def channel_steps(angle: np.ndarray, channels: np.ndarray, *, scale_from: np.ndarray, step: float,
                  deflection: np.ndarray, index: np.ndarray | None = None) -> ModelSteps:
    """Steps already taken: y (m,) and the channels (c, m) at them, the torque whose size sets
    the diffuse start (``scale_from``, not z: it does not change with the model), the step (s)
    and the deflection (m,). One record: the filter does not restart."""
    y = np.asarray(angle, dtype=float)
    chans = np.ascontiguousarray(channels, dtype=float)
    return ModelSteps(index=np.arange(len(y)) if index is None else np.asarray(index), angle=y, channels=chans,
                      slopes=initial_slopes(y, chans), increments=_increments(y),
                      deflection=np.ascontiguousarray(deflection, dtype=float), initial_cov=initial_cov(y, scale_from),
                      step=float(step), restart=np.zeros(len(y), dtype=bool))
