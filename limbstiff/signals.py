"""Filters and derivatives of recorded signals, and the choice of their bandwidth.

Two chains produce a signal and its time derivatives:

* ``zero-phase`` (offline, the default): a Butterworth low-pass run forwards and backwards
  (no phase lag, so torque and angle keep their phase relation), then central differences;
* ``paper`` (causal, Sec. V of Grioli & Bicchi 2010): a second-order prefilter 1/(τs + 1)²
  followed by repeated "dirty derivatives" D(s) = s/(1 + τ_d s) (eq. 11).

Both chains must be applied with the same settings to every channel of a trial. Pure
numpy/scipy: no I/O.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import signal

#: Highest low-pass corner used, as a fraction of the sampling rate. Above it the filter is
#: skipped: the data are already as smooth as their sampling allows, and a Butterworth corner
#: near Nyquist distorts the third derivative (measured: 3 % stiffness error at 0.4·fs).
MAX_BANDWIDTH_FRACTION = 0.25


@dataclass(frozen=True)
class Bandwidth:
    """The low-pass corner chosen for a trial, and what it was chosen from.

    Parameters
    ----------
    cutoff_hz : float or None, Hz
        Corner of the zero-phase low-pass; None when no filtering is needed.
    signal_edge_hz : float, Hz
        Highest frequency at which the angle's spectrum stands clear of its noise floor.
    noise_floor : float, rad²/Hz (m²/Hz)
        Level of the angle's spectrum at high frequency (noise and quantisation).
    quantisation_step : float, rad (m)
        Smallest step between distinct angle values (0 if the angle looks continuous).
    """

    cutoff_hz: float | None
    signal_edge_hz: float
    noise_floor: float
    quantisation_step: float

    def to_dict(self) -> dict:
        return {"cutoff_hz": self.cutoff_hz, "signal_edge_hz": self.signal_edge_hz,
                "noise_floor": self.noise_floor, "quantisation_step": self.quantisation_step}


def quantisation_step(x: np.ndarray) -> float:
    """Smallest step of a quantised signal, or 0 when it looks continuous.

    Parameters
    ----------
    x : ndarray, shape (n,)

    Returns
    -------
    float
        The step q when at least 95 % of the non-zero sample-to-sample changes are integer
        multiples of one q; 0 otherwise.
    """
    steps = np.abs(np.diff(x))
    steps = steps[steps > 1e-12 * max(np.max(np.abs(x)), 1e-300)]
    if steps.size < 10:
        return 0.0
    q = float(np.percentile(steps, 1))
    if q <= 0:
        return 0.0
    ratio = steps / q
    on_grid = np.abs(ratio - np.round(ratio)) < 0.02
    return q if np.mean(on_grid) > 0.95 else 0.0


def welch_spectrum(x: np.ndarray, fs: float, *, seconds: float = 4.0) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectrum of the detrended signal by Welch's method.

    Segments are the power of two nearest above ``seconds`` of data (at least 256 samples, at
    most the whole signal), so the resolution is about 1/``seconds`` Hz whatever the rate.

    Parameters
    ----------
    x : ndarray, shape (n,)
    fs : float, Hz
    seconds : float, s
        Segment length wanted.

    Returns
    -------
    freq : ndarray, shape (m,), Hz
    psd : ndarray, shape (m,), unit of x squared per Hz
    """
    x = signal.detrend(np.asarray(x, dtype=float))
    nperseg = int(min(len(x), max(256, 2 ** np.ceil(np.log2(seconds * fs)))))
    return signal.welch(x, fs=fs, nperseg=nperseg)


def _floor(freq: np.ndarray, psd: np.ndarray) -> float:
    return float(np.median(psd[freq >= 0.8 * freq[-1]]))


def spectral_floor(x: np.ndarray, fs: float) -> float:
    """Noise floor of a recorded signal: the median Welch level over the top fifth of the band,
    where a physiological or mechanical motion has no power left (unit of x squared per Hz)."""
    return _floor(*welch_spectrum(x, fs))


def _spectral_edge(x: np.ndarray, fs: float, snr: float) -> tuple[float, float]:
    """Highest frequency whose Welch level exceeds ``snr`` × the noise floor, and that floor."""
    freq, psd = welch_spectrum(x, fs)
    floor = _floor(freq, psd)
    above = np.flatnonzero(psd > snr * max(floor, 1e-300))
    return (float(freq[above[-1]]) if above.size else float(freq[1])), floor


def choose_bandwidth(angle: np.ndarray, fs: float, *, torque: np.ndarray | None = None,
                     snr: float = 100.0) -> Bandwidth:
    """Low-pass corner for the derivatives, from the recorded spectra themselves.

    Each spectrum (Welch) is compared with its noise floor (median level over the top fifth
    of the band, where a physiological or mechanical motion has no power left). A channel's
    signal edge is the highest frequency whose level exceeds ``snr`` × floor (20 dB); the
    trial's edge is the lower of the angle's and the torque's, since the stiffness is only
    seen where both carry signal. The corner sits 1.5× above the edge so that the excitation
    band passes unattenuated; when it reaches the top of the band (noise-free or coarsely
    sampled data) no filter is applied.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad (m)
    fs : float, Hz
    torque : ndarray, shape (n,), N·m (N), optional
    snr : float
        Power ratio to the noise floor that counts as signal.

    Returns
    -------
    Bandwidth
    """
    edge, floor = _spectral_edge(angle, fs, snr)
    if torque is not None:
        edge = min(edge, _spectral_edge(torque, fs, snr)[0])
    cutoff = 1.5 * edge
    return Bandwidth(cutoff_hz=None if cutoff >= MAX_BANDWIDTH_FRACTION * fs else cutoff,
                     signal_edge_hz=edge, noise_floor=floor, quantisation_step=quantisation_step(angle))


def zero_phase_lowpass(x: np.ndarray, fs: float, cutoff_hz: float | None, *, order: int = 4) -> np.ndarray:
    """Butterworth low-pass run forwards and backwards (no phase lag).

    Parameters
    ----------
    x : ndarray, shape (n,), or (k, n): each row filtered (as it would be alone)
    fs : float, Hz
    cutoff_hz : float or None, Hz
        Corner; None returns a copy of ``x``.
    order : int
        Order of the filter in each direction.

    Returns
    -------
    ndarray, shape of ``x``
    """
    x = np.asarray(x, dtype=float)
    if cutoff_hz is None:
        return x.copy()
    sos = _butterworth(order, float(cutoff_hz), float(fs))
    return signal.sosfiltfilt(sos, x, padtype="odd", padlen=min(x.shape[-1] - 1, int(3 * fs / cutoff_hz)))


@functools.lru_cache(maxsize=64)
def _butterworth(order: int, cutoff_hz: float, fs: float) -> np.ndarray:
    """Second-order sections of a Butterworth low-pass, designed once per (order, corner, rate)
    (the diagnosis filters hundreds of signals with the same one)."""
    return signal.butter(order, cutoff_hz, fs=fs, output="sos")


# Central-difference stencils of accuracy order 8 (9 points): the error on a sinusoid of
# ω·Ts = 0.75 (8 Hz at the paper's 66.7 Hz) is ~(ωTs)⁸/630 ≈ 2·10⁻⁴, against (ωTs)²/6 ≈ 9 %
# for the three-point difference.
CENTRAL_FIRST = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
CENTRAL_SECOND = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


def _stencil(x: np.ndarray, kernel: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    half = len(kernel) // 2
    if len(x) <= 2 * half:
        return fallback
    out = np.convolve(x, kernel[::-1], mode="same")
    out[:half] = fallback[:half]
    out[-half:] = fallback[-half:]
    return out


def central_derivatives(x: np.ndarray, fs: float, order: int) -> np.ndarray:
    """The signal and its first ``order`` derivatives by eighth-order central differences.

    The four samples at each end use second-order one-sided differences instead.

    Parameters
    ----------
    x : ndarray, shape (n,)
    fs : float, Hz
    order : int
        Highest derivative wanted.

    Returns
    -------
    ndarray, shape (order + 1, n)
        Row j is the j-th derivative (units of x per s^j).
    """
    h = 1.0 / fs
    out = np.empty((order + 1, len(x)))
    out[0] = x
    if order >= 1:
        out[1] = _stencil(x, CENTRAL_FIRST / h, np.gradient(x, h, edge_order=2))
    if order >= 2:
        out[2] = _stencil(x, CENTRAL_SECOND / h ** 2, np.gradient(out[1], h, edge_order=2))
    for j in range(3, order + 1):
        out[j] = _stencil(out[j - 1], CENTRAL_FIRST / h, np.gradient(out[j - 1], h, edge_order=2))
    return out


def paper_derivatives(x: np.ndarray, fs: float, order: int, *, prefilter_time_constant: float,
                      dirty_derivative_time_constant: float) -> np.ndarray:
    """The causal signal chain of Sec. V: prefilter, then dirty derivatives (eq. 11).

    The prefilter 1/(τs + 1)² is discretised by the bilinear transform. The dirty derivative
    D(s) = s/(1 + τ_d s) is discretised by the backward difference s ≈ (1 − z⁻¹)/Ts, which
    keeps its pole real and inside the unit circle for any τ_d: with the paper's τ_d = 10⁻⁴ s
    and Ts = 0.015 s the bilinear map would put the pole at z ≈ −0.97 and ring at Nyquist.

    Parameters
    ----------
    x, fs, order
        As for :func:`central_derivatives`.
    prefilter_time_constant : float, s
    dirty_derivative_time_constant : float, s

    Returns
    -------
    ndarray, shape (order + 1, n)
        Row 0 is the prefiltered signal, row j its j-th dirty derivative.
    """
    ts = 1.0 / fs
    tau = prefilter_time_constant
    b, a = signal.bilinear([1.0], [tau * tau, 2 * tau, 1.0], fs=fs)
    zi = signal.lfilter_zi(b, a) * x[0]
    out = np.empty((order + 1, len(x)))
    out[0] = signal.lfilter(b, a, x, zi=zi)[0]
    tau_d = dirty_derivative_time_constant
    # D(z) = (1 − z⁻¹) / ((Ts + τ_d) − τ_d z⁻¹)
    bd = np.array([1.0, -1.0]) / (ts + tau_d)
    ad = np.array([1.0, -tau_d / (ts + tau_d)])
    for j in range(1, order + 1):
        zi = signal.lfilter_zi(bd, ad) * out[j - 1][0]
        out[j] = signal.lfilter(bd, ad, out[j - 1], zi=zi)[0]
    return out


def edge_samples(fs: float, cutoff_hz: float | None) -> int:
    """Samples at each end of a trial whose derivatives are not to be trusted.

    The nine-point stencil falls back to one-sided differences over the last four samples,
    and the zero-phase filter's start-up transient spans about half a period of its corner.
    """
    return 4 + (0 if cutoff_hz is None else int(np.ceil(0.5 * fs / cutoff_hz)))


def robust_sd(x: np.ndarray) -> float:
    """Standard deviation of the bulk of ``x`` from its median absolute deviation (× 1.4826, exact
    for Gaussian data), blind to the few outliers and steps a recording has."""
    x = np.asarray(x, dtype=float)
    return float(np.median(np.abs(x - np.median(x)))) * 1.4826


def white_noise_sd(x: np.ndarray) -> float:
    """Standard deviation of the white noise on a smooth signal, from its second differences:
    white noise of sd s gives sd s in Δ²x/√6, while a smooth signal leaves almost nothing there."""
    return robust_sd(np.diff(x, 2) / np.sqrt(6.0))


def velocity_noise_level(angle: np.ndarray, fs: float, cutoff_hz: float | None) -> float:
    """Standard deviation of the noise in the velocity estimate, rad/s (m/s).

    The angle's noise is taken as white with the variance of its high-frequency residual
    (or q²/12 for a quantised encoder, whichever is larger); differentiating and low-passing at
    ``cutoff_hz`` gives a velocity noise variance σ²·(2/fs)·(2π)²·f_c³/3.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad (m)
    fs : float, Hz
    cutoff_hz : float or None, Hz
        Low-pass corner used for the derivatives (None: the Nyquist frequency).

    Returns
    -------
    float
    """
    fc = fs / 2 if cutoff_hz is None else cutoff_hz
    mad = white_noise_sd(angle)
    q = quantisation_step(angle)
    noise_sd = max(mad, q / np.sqrt(12.0))
    return float(noise_sd * 2 * np.pi * np.sqrt(2.0 / fs * fc ** 3 / 3.0))


def motion_frequency(angle: np.ndarray, fs: float) -> float:
    """Typical frequency of the motion: the median frequency of the angle's power spectrum, Hz.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad (m)
    fs : float, Hz

    Returns
    -------
    float, Hz
    """
    freq, psd = welch_spectrum(angle, fs, seconds=8.0)
    cum = np.cumsum(psd[1:])
    if cum[-1] <= 0:
        return float(freq[1])
    return float(freq[1:][np.searchsorted(cum, 0.5 * cum[-1])])
