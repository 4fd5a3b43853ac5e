"""A compliant coupling between the limb and the device, seen in the measured dynamic stiffness.

When the angle is measured at the device (a footplate, a handle) and the limb is joined to it
through skin, a shoe or straps, the device's torque-per-angle H(f) = F(f)/Θ(f) is not that of one
body, K − ω²·I + jω·B, but that of a device inertia I_d plus a coupling Z_c = k_c + jω·b_c in
series with the limb Z_l = K + jω·B_l − ω²·I_l:

    H(ω) = −ω²·I_d + Z_c·Z_l / (Z_c + Z_l),

with a resonance of the limb on the coupling at √((k_c + K)/I_l)/2π. Below it a one-body model
sees the springs in series, K·k_c/(K + k_c): the stiffness estimate is low by K/(K + k_c).

:func:`detect_coupling` estimates H(f) from the recording (Welch cross-spectra), fits both
models weighted by the estimate's own noise, and accepts the coupling only when the one-body
model does not describe the response and the two-body model does, to within that noise
(reduced χ² ≤ :data:`ADEQUATE_CHI2`), while one body misses it by far more than the noise
(χ² ≥ :data:`INADEQUATE_CHI2`). Measured: simulated couplings of 20–60 Hz give one body χ²
200–2100 and two bodies 2.0–3.4; the clean simulated ankle 2.4 (one body is enough); the five
real ankle trials 95–263 for one body and 7–35 for two (neither describes them: a reflex, not a
coupling, and nothing is corrected); Coulomb friction or hysteresis on the simulated ankle and
platform 6–21 for one body and 2.9–4.1 for two — a nonlinearity the two-body model bends to,
which the first version of this test took for a coupling (errors of 38 % to 4800 % after the
"correction"). The two-body model is fitted only when one body misses by that much, and only a
start that converges counts: the clean simulated elbow's starts ran out of evaluations drifting
towards k_c → 0, and where they stopped differed in the 13th digit between two processes. Then
:meth:`CouplingFit.limb_stiffness` undoes the series springs sample by sample, keeping the
stiffness's course. Pure numpy/scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from . import signals

#: Largest reduced χ² (weighted misfit per degree of freedom) of a model that describes the
#: measured response to within its estimation noise (1 for a perfect model; the simulated
#: couplings with their ±30 % stiffness course give 2.0–3.4, the real trials ≥ 7.0).
ADEQUATE_CHI2 = 5.0
#: Smallest reduced χ² of one body that calls for a coupling: a misfit of at least √50 ≈ 7 times
#: the estimation noise (simulated couplings ≥ 200; nonlinear friction and hysteresis ≤ 21).
INADEQUATE_CHI2 = 50.0
#: Largest factor by which undoing the coupling may raise the stiffness, k_c/(k_c − K'): beyond
#: it the coupling is softer than the limb and the limb's stiffness cannot be told apart from it
#: (a 20 Hz coupling on the simulated 60 N·m/rad ankle needs 1.7).
MAX_CORRECTION = 2.0
#: Frequencies used: above this many motion frequencies (the slow motion's own harmonics), up
#: to the signal edge, where the coherence exceeds :data:`MIN_COHERENCE`.
LOWEST_MOTIONS, MIN_COHERENCE = 2.0, 0.5
#: Welch segments of about this length, s (1 Hz resolution).
SEGMENT_S = 1.0
#: Starting resonances of the two-body fit, Hz (the fit keeps the best).
START_RESONANCES_HZ = (20.0, 30.0, 45.0, 70.0, 100.0, 150.0)
#: Evaluations of each two-body fit: the fits that end at a coupling or a limb converge within
#: 10–75 (simulated couplings of 20–60 Hz, the real ankles); a start that drives a parameter
#: towards 0 or ∞ never converges and would otherwise run on.
MAX_EVALUATIONS = 400
#: Relative difference of cost below which two converged starts are the same fit (the earlier
#: start is kept): six starts at one minimum of a simulated coupled ankle differed by ~6 ulp.
TIE = 1e-9


@dataclass(frozen=True)
class CouplingFit:
    """What the measured dynamic stiffness says about a coupling.

    Parameters
    ----------
    one_body_chi2, two_body_chi2 : float
        Reduced χ² of each model (1: within the estimation noise). The two-body fit and its
        values are NaN when it is not made (one body's χ² below :data:`INADEQUATE_CHI2`) or when
        none of its starts converged within :data:`MAX_EVALUATIONS`.
    coupling_stiffness : float, N·m/rad
        k_c of the two-body fit.
    resonance_hz : float
        Resonance of the limb on the coupling.
    limb_stiffness_fit : float, N·m/rad
        K of the two-body fit (a constant: the trial's typical stiffness).
    band_hz : (float, float)
        Frequencies fitted.
    """

    one_body_chi2: float
    two_body_chi2: float
    coupling_stiffness: float
    resonance_hz: float
    limb_stiffness_fit: float
    band_hz: tuple[float, float]

    @property
    def found(self) -> bool:
        """One body does not describe the response, a limb on a coupling does, with its
        resonance inside the band fitted."""
        lo, hi = self.band_hz
        return bool(self.one_body_chi2 >= INADEQUATE_CHI2 and self.two_body_chi2 <= ADEQUATE_CHI2
                    and lo <= self.resonance_hz <= hi and self.coupling_stiffness > 0)

    def correction(self, series: float) -> float:
        """k_c/(k_c − K'): the factor undoing the series springs at stiffness ``series`` (inf at
        or beyond k_c)."""
        kc = self.coupling_stiffness
        return kc / (kc - series) if series < kc else np.inf

    def limb_stiffness(self, series: np.ndarray) -> np.ndarray:
        """The limb's stiffness from the springs-in-series one, K = K'·k_c/(k_c − K'), (n,);
        NaN where K' ≥ k_c (no limb stiffness gives it)."""
        kc = self.coupling_stiffness
        series = np.asarray(series, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(series < kc, series * kc / (kc - series), np.nan)

    def to_dict(self) -> dict:
        return {"found": self.found, "one_body_chi2": self.one_body_chi2, "two_body_chi2": self.two_body_chi2,
                "coupling_stiffness": self.coupling_stiffness, "resonance_hz": self.resonance_hz,
                "limb_stiffness_fit": self.limb_stiffness_fit, "band_hz": list(self.band_hz),
                "adequate_chi2": ADEQUATE_CHI2, "inadequate_chi2": INADEQUATE_CHI2}


def dynamic_stiffness(angle: np.ndarray, torque: np.ndarray, fs: float):
    """H(f) = S_θf/S_θθ with its coherence and the number of independent averages.

    Returns
    -------
    freq : ndarray, Hz
    response : ndarray of complex, N·m/rad
    coherence : ndarray
    averages : float
    """
    n = int(min(len(angle), 2 ** np.ceil(np.log2(SEGMENT_S * fs))))
    x, y = signal.detrend(np.asarray(angle, float)), signal.detrend(np.asarray(torque, float))
    freq, pxy = signal.csd(x, y, fs=fs, nperseg=n)
    _, pxx = signal.welch(x, fs=fs, nperseg=n)
    _, pyy = signal.welch(y, fs=fs, nperseg=n)
    with np.errstate(divide="ignore", invalid="ignore"):   # a constant channel: no coherence (nan), no warning
        coh = np.abs(pxy) ** 2 / pxx / pyy   # scipy.signal.coherence's own expression, without its two passes more
    segments = (len(x) - n) // (n // 2) + 1
    # half-overlapped Hann segments are worth ~1/1.9 independent ones each
    return freq, pxy / np.maximum(pxx, 1e-300), coh, max(1.0, segments / 1.9)


def _two_body(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    device, kc, bc, k, b, inertia = p
    limb = k + 1j * w * b - w ** 2 * inertia
    joint = kc + 1j * w * bc
    return -w ** 2 * device + joint * limb / (joint + limb)


def _fit_one_body(w, h, weight) -> tuple[np.ndarray, float]:
    """(K, I, B) by weighted linear least squares, and the reduced χ²."""
    design = np.vstack([np.ones_like(w), -w ** 2]).T
    (k, inertia), *_ = np.linalg.lstsq(design * weight[:, None], h.real * weight, rcond=None)
    b = float(np.sum(weight ** 2 * w * h.imag) / np.sum(weight ** 2 * w * w))
    fitted = k - w ** 2 * inertia + 1j * w * b
    return np.array([k, inertia, b]), float(np.sum(np.abs(weight * (h - fitted)) ** 2) / max(2 * len(w) - 3, 1))


def _two_body_gradient(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """∂H/∂ln p of :func:`_two_body`, shape (len(w), 6): p_i·∂H/∂p_i, with ∂(J·L/(J + L))/∂J =
    L²/(J + L)² and ∂/∂L = J²/(J + L)² for the coupling J and the limb L."""
    device, kc, bc, k, b, inertia = p
    limb = k + 1j * w * b - w ** 2 * inertia
    joint = kc + 1j * w * bc
    d_joint, d_limb = (limb / (joint + limb)) ** 2, (joint / (joint + limb)) ** 2
    return np.column_stack([-w ** 2 * device + 0j, kc * d_joint, 1j * w * bc * d_joint,
                            k * d_limb, 1j * w * b * d_limb, -w ** 2 * inertia * d_limb])


def _fit_two_body(w, h, weight, one: np.ndarray) -> tuple[np.ndarray, float]:
    """(I_d, k_c, b_c, K, B_l, I_l) by nonlinear least squares on their logarithms, from several
    starting resonances; the reduced χ² of the best. The Jacobian is exact
    (:func:`_two_body_gradient`): by finite differences, a trial whose starts do not converge
    spent ~2 s of its analysis here."""
    k, inertia, b = max(one[0], 1e-3), max(one[1], 1e-5), max(one[2], 1e-3)

    def residual(x):
        r = weight * (h - _two_body(np.exp(x), w))
        return np.concatenate([r.real, r.imag])

    def jacobian(x):
        d = -weight[:, None] * _two_body_gradient(np.exp(x), w)
        return np.concatenate([d.real, d.imag])

    best = None
    for f0 in START_RESONANCES_HZ:
        kc = inertia * (2 * np.pi * f0) ** 2
        x0 = np.log([0.1 * inertia, kc, 0.1 * np.sqrt(kc * inertia), k, b, inertia])
        with np.errstate(all="ignore"):
            fit = optimize.least_squares(residual, x0, jac=jacobian, method="lm", max_nfev=MAX_EVALUATIONS)
        # a start that ran out of evaluations drifted towards 0 or ∞: where it stopped is no
        # fit, and its last digits differ between processes (the parallel run's summary did);
        # starts that end at the same minimum tie to ~1e-15, so a later one must be better by
        # more than that to be taken
        if fit.status > 0 and np.isfinite(fit.cost) and (best is None or fit.cost < best.cost * (1 - TIE)):
            best = fit
    if best is None:
        return np.full(6, np.nan), float("nan")
    return np.exp(best.x), float(2 * best.cost / max(2 * len(w) - 6, 1))


def detect_coupling(angle: np.ndarray, torque: np.ndarray, fs: float, *, motion_hz: float,
                    signal_edge_hz: float) -> CouplingFit | None:
    """Fit one body and a limb on a coupling to the measured dynamic stiffness.

    Parameters
    ----------
    angle, torque : ndarray, shape (n,)
        As recorded, rad and N·m (the external torque at the device).
    fs : float, Hz
    motion_hz, signal_edge_hz : float, Hz
        The band: from :data:`LOWEST_MOTIONS` motion frequencies to the signal edge (at most fs/4).

    Returns
    -------
    CouplingFit or None
        None when fewer than 12 frequencies are coherent enough to fit.
    """
    freq, h, coh, averages = dynamic_stiffness(angle, torque, fs)
    top = min(signal_edge_hz, signals.MAX_BANDWIDTH_FRACTION * fs)
    use = (freq > LOWEST_MOTIONS * motion_hz) & (freq <= top) & (coh > MIN_COHERENCE) & np.isfinite(h)
    if use.sum() < 12:
        return None
    w, h, c = 2 * np.pi * freq[use], h[use], coh[use]
    # the H₁ estimate's relative variance is (1 − γ²)/(2·n·γ²) for n averages
    weight = np.sqrt(2 * averages * c / np.maximum(1 - c, 1e-12)) / np.abs(h)
    one, chi_one = _fit_one_body(w, h, weight)
    # one body describes the response: no coupling can be found, and the two-body fit is not made
    two, chi_two = (_fit_two_body(w, h, weight, one) if chi_one >= INADEQUATE_CHI2
                    else (np.full(6, np.nan), float("nan")))
    _, kc, _, k, _, inertia = two
    # a degenerate fit (the limb's inertia driven to 0) has no resonance in any band
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        resonance = np.sqrt((kc + k) / inertia) / (2 * np.pi) if inertia > 0 else np.inf
    if not np.isfinite(two).all():
        resonance = float("nan")
    return CouplingFit(one_body_chi2=chi_one, two_body_chi2=chi_two, coupling_stiffness=float(kc),
                       resonance_hz=float(resonance), limb_stiffness_fit=float(k),
                       band_hz=(float(freq[use][0]), float(freq[use][-1])))
