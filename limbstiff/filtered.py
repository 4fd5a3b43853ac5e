"""A trial's signals through one filter chain: built once, used by every later step.

:func:`filter_trial` turns a :class:`~limbstiff.trial.Trial` into a :class:`Filtered`: the
angle and its first three derivatives and the torque of the analysed variant with its rate,
all through the same chain (zero-phase Butterworth at a corner chosen from the data, or the
paper's causal chain), with what was chosen from the data on the way (corner, motion
frequency, noise levels, edge samples). The identification, the estimators, the report and the
diagnosis all read this one object; none filters the recording again. Pure numpy/scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import signals
from .errors import TrialError
from .protocol import Protocol
from .trial import Trial

VARIANTS = ("external", "direct")


@dataclass(frozen=True)
class FilterChain:
    """One filter chain, applied alike to every channel of a trial.

    Parameters
    ----------
    kind : {"zero-phase", "paper"}
        Zero-phase Butterworth then central differences, or the paper's causal chain (Sec. V).
    fs : float, Hz
    cutoff_hz : float or None, Hz
        Corner of the zero-phase low-pass (None: not filtered; always None for the paper chain).
    prefilter_time_constant, dirty_derivative_time_constant : float, s
        Settings of the paper chain.
    """

    kind: str
    fs: float
    cutoff_hz: float | None
    prefilter_time_constant: float
    dirty_derivative_time_constant: float

    def apply(self, x: np.ndarray, order: int) -> np.ndarray:
        """``x`` (n,) filtered, with its first ``order`` derivatives: shape (order + 1, n)."""
        x = np.asarray(x, dtype=float)
        if self.kind == "paper":
            return signals.paper_derivatives(x, self.fs, order,
                                             prefilter_time_constant=self.prefilter_time_constant,
                                             dirty_derivative_time_constant=self.dirty_derivative_time_constant)
        smooth = signals.zero_phase_lowpass(x, self.fs, self.cutoff_hz)
        return smooth[None, :] if order == 0 else signals.central_derivatives(smooth, self.fs, order)

    @property
    def edge(self) -> int:
        """Samples at each end whose derivatives are not to be trusted."""
        return signals.edge_samples(self.fs, self.cutoff_hz)


@dataclass(frozen=True)
class Filtered:
    """The signals of one trial, filtered alike, and the settings derived from them.

    Parameters
    ----------
    variant : {"external", "direct"}
        ``torque`` is the external torque (external variant) or the elastic one (direct).
    sample_period : float, s
        Ts, as the trial gives it (``fs`` is its inverse).
    angle, velocity, acceleration, jerk : ndarray, shape (n,)
        y, ẏ, ÿ, y⃛ in rad, rad/s, rad/s², rad/s³ (m, m/s… for translational trials).
    torque, torque_rate : ndarray, shape (n,)
        f and ḟ, N·m and N·m/s (N, N/s).
    chain : FilterChain
        The chain every channel went through (and any torque compared with them must).
    bandwidth : signals.Bandwidth
        The corner applied and what it was chosen from (signal edge, noise floor, quantisation).
    motion_hz : float, Hz
        Typical motion frequency (median frequency of the angle's spectrum).
    velocity_noise : float, rad/s (m/s)
        Standard deviation of the noise in ẏ.
    angle_noise : float, rad (m)
        Standard deviation of the white noise on the recorded angle.
    torque_quantisation_step : float, N·m (N)
        Step of the recorded torque (0 when continuous).
    torque_noise_floor : float, (N·m)²/Hz
        One-sided spectral floor of the recorded torque.
    """

    variant: str
    sample_period: float
    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    torque: np.ndarray
    torque_rate: np.ndarray
    chain: FilterChain
    bandwidth: signals.Bandwidth
    motion_hz: float
    velocity_noise: float
    angle_noise: float
    torque_quantisation_step: float
    torque_noise_floor: float

    @property
    def fs(self) -> float:
        """Sampling rate, Hz."""
        return 1.0 / self.sample_period

    @property
    def n(self) -> int:
        return len(self.angle)

    @property
    def cutoff_hz(self) -> float | None:
        """Corner of the zero-phase low-pass applied, Hz (None: none)."""
        return self.chain.cutoff_hz

    @property
    def edge(self) -> int:
        """Samples at each end whose derivatives are not to be trusted."""
        return self.chain.edge

    @property
    def angle_resolution(self) -> float:
        """Smallest angle change the recording resolves, rad: max(q/√12, noise sd)."""
        return float(max(self.bandwidth.quantisation_step / np.sqrt(12.0), self.angle_noise))

    def lowpass(self, x: np.ndarray) -> np.ndarray:
        """``x`` (n,) through the same low-pass as the recorded channels (or (k, n), each row, on a
        zero-phase chain)."""
        return self.differentiate(x, 0)[0]

    def differentiate(self, x: np.ndarray, order: int) -> np.ndarray:
        """``x`` (n,) filtered and differentiated like the angle: shape (order + 1, n)."""
        return self.chain.apply(x, order)

    def elastic_torque(self, inertia: float = 0.0, damping: float = 0.0) -> np.ndarray:
        """z = f − m·ÿ − b·ẏ: the torque left to the elastic element, N·m (n,)."""
        return self.torque - inertia * self.acceleration - damping * self.velocity


def variant_of(trial: Trial, protocol: Protocol) -> str:
    """The variant the protocol asks for (``auto``: the trial's own), checked against its columns."""
    where = trial.source or trial.name
    variant = trial.variant if protocol.variant == "auto" else protocol.variant
    if variant == "direct" and trial.elastic_torque is None:
        raise TrialError(where, "the direct variant needs an elastic torque/force column")
    if variant == "external" and trial.torque is None:
        raise TrialError(where, "the external variant needs an external torque/force column")
    return variant


#: ``corner_hz`` of :func:`filter_trial` when the corner is the protocol's or the spectra's.
FROM_PROTOCOL = "protocol"


def filter_trial(trial: Trial, protocol: Protocol, *, corner_hz: float | None | str = FROM_PROTOCOL) -> Filtered:
    """Filter and differentiate a trial's angle and torque, the same chain for both.

    The corner comes from ``corner_hz`` when given (None: no filter), else from the protocol
    (``bandwidth_hz``) or from the spectra of the recorded angle and torque
    (:func:`signals.choose_bandwidth`); a corner at or above
    :data:`signals.MAX_BANDWIDTH_FRACTION` of the rate is not applied.

    Raises
    ------
    TrialError
        When the variant's torque column is missing.
    """
    variant = variant_of(trial, protocol)
    fs = trial.fs
    torque = trial.torque if variant == "external" else trial.elastic_torque
    recorded = trial.torque if trial.torque is not None else trial.elastic_torque
    chosen = signals.choose_bandwidth(trial.angle, fs, torque=recorded)
    if protocol.derivatives == "paper":
        cutoff = None
    elif corner_hz != FROM_PROTOCOL:
        cutoff = corner_hz
    else:
        cutoff = protocol.bandwidth_hz if protocol.bandwidth_hz is not None else chosen.cutoff_hz
        if cutoff is not None and cutoff >= signals.MAX_BANDWIDTH_FRACTION * fs:
            cutoff = None
    bandwidth = signals.Bandwidth(cutoff_hz=cutoff, signal_edge_hz=chosen.signal_edge_hz,
                                  noise_floor=chosen.noise_floor, quantisation_step=chosen.quantisation_step)
    chain = FilterChain(kind=protocol.derivatives, fs=float(fs), cutoff_hz=cutoff,
                        prefilter_time_constant=protocol.prefilter_time_constant,
                        dirty_derivative_time_constant=protocol.dirty_derivative_time_constant)
    y = chain.apply(trial.angle, 3)
    f = chain.apply(torque, 1)
    return Filtered(
        variant=variant, sample_period=trial.sample_period, angle=y[0], velocity=y[1], acceleration=y[2], jerk=y[3],
        torque=f[0], torque_rate=f[1], chain=chain, bandwidth=bandwidth,
        motion_hz=signals.motion_frequency(y[0], fs),
        velocity_noise=signals.velocity_noise_level(trial.angle, fs, cutoff),
        angle_noise=signals.white_noise_sd(trial.angle),
        torque_quantisation_step=signals.quantisation_step(recorded),
        torque_noise_floor=signals.spectral_floor(torque, fs))
