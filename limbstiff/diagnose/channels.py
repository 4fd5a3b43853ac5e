"""The signals of one trial as the diagnosis sees them, filtered like the stiffness analysis.

A :class:`Channels` holds, at the trial's full rate, the angle and its first two derivatives
and the torque, all through the same filter chain the analysis used (zero-phase Butterworth
at the data-chosen corner, or the paper's causal chain), together with the inertia and damping
the analysis used and its stiffness course. Every unmodelled torque a candidate effect adds is
passed through the same filter (:meth:`Channels.lowpass`) so that it is compared with the
recorded torque on equal terms. Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import signals
from ..analysis import derivatives
from ..protocol import Protocol
from ..trial import Trial


@dataclass(frozen=True)
class Channels:
    """Filtered signals of one trial and the nominal model the stiffness analysis used.

    Parameters
    ----------
    name : str
        Trial name.
    time : ndarray, shape (n,), s
    angle : ndarray, shape (3, n)
        y, ẏ, ÿ after the analysis's filter chain (rad, rad/s, rad/s²; m… for translational).
    torque : ndarray, shape (n,), N·m (N)
        The torque the model predicts (external, or elastic for the direct variant), filtered
        alike.
    raw_angle, raw_torque : ndarray, shape (n,)
        As recorded (SI units).
    inertia, damping : float
        m (kg·m²) and b (N·m·s/rad) of the nominal model (0 for the direct variant).
    mechanics : str
        ``"given"`` (protocol or command line), ``"identified"`` (from this trial) or
        ``"none"`` (direct variant).
    stiffness : ndarray, shape (n,), N·m/rad
        The stiffness course the analysis estimated.
    observable : ndarray of bool, shape (n,)
    fs : float, Hz
    cutoff_hz : float or None
        Corner of the zero-phase low-pass (None: unfiltered, or the paper chain).
    chain : str
        ``"zero-phase"`` or ``"paper"``.
    prefilter_time_constant, dirty_derivative_time_constant : float, s
        Settings of the paper chain.
    motion_hz : float
        Typical motion frequency (median frequency of the angle spectrum).
    velocity_noise : float, rad/s
        Standard deviation of the noise in ẏ (``signals.velocity_noise_level``).
    quantisation_step : float, rad
        Encoder step of the recorded angle (0 when continuous).
    angle_noise : float, rad
        Standard deviation of the angle's white noise (from second differences, robustly).
    torque_floor, angle_floor : float
        One-sided spectral floors of the recorded torque ((N·m)²/Hz) and angle (rad²/Hz).
    edge : int
        Samples at each end whose derivatives are not trusted.
    """

    name: str
    time: np.ndarray
    angle: np.ndarray
    torque: np.ndarray
    raw_angle: np.ndarray
    raw_torque: np.ndarray
    inertia: float
    damping: float
    mechanics: str
    stiffness: np.ndarray
    observable: np.ndarray
    fs: float
    cutoff_hz: float | None
    chain: str
    prefilter_time_constant: float
    dirty_derivative_time_constant: float
    motion_hz: float
    velocity_noise: float
    quantisation_step: float
    angle_noise: float
    torque_floor: float
    angle_floor: float
    edge: int

    @property
    def angle_resolution(self) -> float:
        """Smallest angle change the recording resolves, rad: max(q/√12, noise sd)."""
        return float(max(self.quantisation_step / np.sqrt(12.0), self.angle_noise))

    @property
    def n(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    def lowpass(self, x: np.ndarray) -> np.ndarray:
        """``x`` through the same low-pass as the recorded channels (shape (n,))."""
        x = np.asarray(x, float)
        if self.chain == "paper":
            return signals.paper_derivatives(x, self.fs, 0,
                                             prefilter_time_constant=self.prefilter_time_constant,
                                             dirty_derivative_time_constant=self.dirty_derivative_time_constant)[0]
        return signals.zero_phase_lowpass(x, self.fs, self.cutoff_hz)

    def linear_part(self, x: np.ndarray) -> np.ndarray:
        """Least-squares fit of ``x`` (n,) on 1, y, ẏ, ÿ."""
        key = "_linear_basis"
        q = self.__dict__.get(key)
        if q is None:
            basis = np.column_stack([np.ones(self.n), self.angle[0], self.angle[1], self.angle[2]])
            basis = basis / np.maximum(np.linalg.norm(basis, axis=0), 1e-300)
            q = np.linalg.qr(basis)[0]
            object.__setattr__(self, key, q)
        return q @ (q.T @ np.asarray(x, float))

    def differentiate(self, x: np.ndarray, order: int = 2) -> np.ndarray:
        """``x`` filtered and differentiated like the angle: shape (order + 1, n)."""
        if self.chain == "paper":
            return signals.paper_derivatives(np.asarray(x, float), self.fs, order,
                                             prefilter_time_constant=self.prefilter_time_constant,
                                             dirty_derivative_time_constant=self.dirty_derivative_time_constant)
        return signals.central_derivatives(self.lowpass(x), self.fs, order)

    def with_channels(self, *, angle: np.ndarray | None = None, torque: np.ndarray | None = None) -> "Channels":
        """A copy with the filtered angle (3, n) or torque (n,) replaced (corrected channels)."""
        changes = {}
        if angle is not None:
            changes["angle"] = angle
        if torque is not None:
            changes["torque"] = torque
        return replace(self, **changes) if changes else self

    def elastic_target(self) -> np.ndarray:
        """z = f − m·ÿ − b·ẏ: the torque the nominal model leaves to the elastic element (n,)."""
        return self.torque - self.inertia * self.angle[2] - self.damping * self.angle[1]


def _angle_noise_sd(angle: np.ndarray) -> float:
    residual = np.diff(angle, 2) / np.sqrt(6.0)        # white noise of sd s gives sd s here
    return float(np.median(np.abs(residual - np.median(residual))) * 1.4826)


def _spectral_floor(x: np.ndarray, fs: float) -> float:
    """One-sided PSD level over the top fifth of the band (the same floor as the bandwidth choice)."""
    from scipy import signal as sps
    x = sps.detrend(np.asarray(x, dtype=float))
    nperseg = int(min(len(x), max(256, 2 ** np.ceil(np.log2(4 * fs)))))
    freq, psd = sps.welch(x, fs=fs, nperseg=nperseg)
    return float(np.median(psd[freq >= 0.8 * freq[-1]]))


def channels_from(trial: Trial, result, protocol: Protocol) -> Channels:
    """Build the :class:`Channels` of a trial from its stiffness analysis.

    Parameters
    ----------
    trial : Trial
    result : StiffnessResult
        The analysis of ``trial`` with ``protocol`` (gives m, b, σ̂ and the bandwidth).
    protocol : Protocol
        The settings the analysis ran with (same filter chain).

    Returns
    -------
    Channels
    """
    angle, torques, bandwidth = derivatives(trial, protocol, order=2)
    external = result.variant == "external"
    torque = torques["torque" if external else "elastic_torque"][0]
    raw_torque = trial.torque if external else trial.elastic_torque
    if external:
        m, b = result.inertia.median, result.damping.median
        ident = (result.details.get("identification") or {}).get("method")
        mechanics = "given" if ident == "given" else "identified"
    else:
        m = b = 0.0
        mechanics = "none"
    cutoff = bandwidth.cutoff_hz
    q = bandwidth.quantisation_step
    noise_sd = _angle_noise_sd(trial.angle)
    return Channels(
        name=trial.name, time=np.asarray(trial.time, float), angle=angle, torque=torque,
        raw_angle=np.asarray(trial.angle, float), raw_torque=np.asarray(raw_torque, float),
        inertia=float(m), damping=float(b), mechanics=mechanics,
        stiffness=np.asarray(result.stiffness, float), observable=np.asarray(result.observable, bool),
        fs=float(trial.fs), cutoff_hz=cutoff, chain=protocol.derivatives,
        prefilter_time_constant=protocol.prefilter_time_constant,
        dirty_derivative_time_constant=protocol.dirty_derivative_time_constant,
        motion_hz=float(result.details["motion_frequency_hz"]),
        velocity_noise=float(signals.velocity_noise_level(trial.angle, trial.fs, cutoff)),
        quantisation_step=float(q), angle_noise=noise_sd,
        torque_floor=_spectral_floor(raw_torque, trial.fs), angle_floor=_spectral_floor(trial.angle, trial.fs),
        edge=int(signals.edge_samples(trial.fs, cutoff)))
