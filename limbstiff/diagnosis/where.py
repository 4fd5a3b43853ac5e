"""Where the gap lies: the residual located in time, in frequency and by operating regime,
its whiteness and its cross-correlation with the input, each with its confidence bound.

Pure functions over numpy arrays (no I/O, no plotting). Conventions: ``residual`` is the
measured minus the predicted torque (N·m), ``level`` a two-sided confidence level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal as sps
from scipy import stats

from ..signals import robust_sd


@dataclass(frozen=True, eq=False)
class Whiteness:
    """An autocorrelation (Ljung–Box) test of whiteness.

    Parameters
    ----------
    lags : ndarray of int, shape (L,)
        Lags 1…L, in samples.
    acf : ndarray, shape (L,)
        Sample autocorrelation at the lags (dimensionless).
    bound : float
        Per-lag bound ±z/√n of a white series (dimensionless).
    reference : ndarray, shape (L,), or None
        Autocorrelation expected under the null hypothesis, when not zero.
    q : float
        Ljung–Box statistic.
    dof : int
        Its degrees of freedom (L).
    p_value : float
    white : bool
        p > 1 − level.
    outside : float
        Share of the lags outside the bound.
    level : float
        Confidence level of the bound and the test.
    sample_period_s : float or None
        Time between samples, s, when the series has one.
    note : str or None
        What the series is, when said.
    """

    lags: np.ndarray
    acf: np.ndarray
    bound: float
    reference: np.ndarray | None
    q: float
    dof: int
    p_value: float
    white: bool
    outside: float
    level: float
    sample_period_s: float | None = None
    note: str | None = None


@dataclass(frozen=True, eq=False)
class CrossCorrelation:
    """The cross-correlation r(k) = corr(residual(t), x(t − k)) with Bartlett's bound.

    Parameters
    ----------
    lags_s : ndarray, shape (2L + 1,), s
        Lags −L…L.
    ccf : ndarray, shape (2L + 1,)
        r at the lags (dimensionless).
    bound : float
        ± bound of two independent series (dimensionless).
    peak_lag_s : float, s
        Lag of the largest |r|: positive when the residual follows x.
    peak : float
        r at the peak.
    significant : bool
        |peak| > bound.
    level : float
    """

    lags_s: np.ndarray
    ccf: np.ndarray
    bound: float
    peak_lag_s: float
    peak: float
    significant: bool
    level: float


@dataclass(frozen=True, eq=False)
class Spectrum:
    """The residual's spectrum against the torque's, and its coherence with the angle.

    Parameters
    ----------
    freq_hz : ndarray, shape (k,), Hz
    residual_psd, torque_psd : ndarray, shape (k,), (N·m)²/Hz
        One-sided Welch estimates.
    ratio : ndarray, shape (k,)
        Residual over torque PSD (0 where the torque's is 0).
    coherence : ndarray, shape (k,)
        Magnitude-squared coherence of the residual with the angle (dimensionless).
    bound : float
        Coherence above which it is significant at ``level``.
    segments : int
        Welch segments.
    level : float
    """

    freq_hz: np.ndarray
    residual_psd: np.ndarray
    torque_psd: np.ndarray
    ratio: np.ndarray
    coherence: np.ndarray
    bound: float
    segments: int
    level: float


@dataclass(frozen=True)
class Bin:
    """The gap within one bin of an operating regime.

    Parameters
    ----------
    bin : str
        The bin's name.
    range : tuple of float or None
        Its range (lo, hi) in the binned quantity's unit, when it has one.
    n : int
        Samples in the bin.
    share : float
        Their share of all samples.
    gap : float or None
        Mean r² in the bin over the record's mean squared torque deviation (None: empty bin).
    ratio : float or None
        Mean r² in the bin over mean r² overall.
    interval : tuple of float or None
        Interval (lo, hi) of ``ratio`` (χ² with n_eff degrees of freedom).
    """

    bin: str
    range: tuple | None
    n: int
    share: float
    gap: float | None = None
    ratio: float | None = None
    interval: tuple | None = None


def _z(level: float) -> float:
    return float(stats.norm.ppf(0.5 + level / 2))


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation ρ(0..max_lag) of x about its mean (biased estimator), shape (L + 1,)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    f = np.fft.rfft(x, 2 * n)
    acov = np.fft.irfft(f * np.conj(f))[:max_lag + 1] / n
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


def whiteness(x: np.ndarray, *, max_lag: int, level: float = 0.95,
              reference: np.ndarray | None = None) -> Whiteness:
    """Autocorrelation test of whiteness (Ljung–Box portmanteau).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Residual (any unit).
    max_lag : int
        Lags 1…max_lag tested.
    level : float
        Confidence level of the per-lag bound ±z/√n and of the test.
    reference : ndarray, shape (max_lag + 1,), optional
        Autocorrelation expected under the null hypothesis (for example filtered white noise);
        the test is then on the departure from it.

    Returns
    -------
    Whiteness
    """
    x = np.asarray(x, float)
    n = len(x)
    acf = autocorrelation(x, max_lag)
    ref = np.zeros(max_lag + 1) if reference is None else np.asarray(reference, float)
    d = (acf - ref)[1:]
    lags = np.arange(1, max_lag + 1)
    q = float(n * (n + 2) * np.sum(d ** 2 / (n - lags)))
    p = float(stats.chi2.sf(q, max_lag))
    bound = _z(level) / np.sqrt(n)
    return Whiteness(lags=lags, acf=acf[1:], bound=bound, reference=None if reference is None else ref[1:], q=q,
                     dof=max_lag, p_value=p, white=p > 1 - level, outside=float(np.mean(np.abs(d) > bound)),
                     level=level)


def cross_correlation(residual: np.ndarray, x: np.ndarray, *, max_lag: int, sample_period: float,
                      level: float = 0.95) -> CrossCorrelation:
    """Cross-correlation r(k) = corr(residual(t), x(t − k)) over lags −L…L, with Bartlett's bound.

    A positive peak lag means the residual follows the input ``x`` that many seconds later.
    For two independent series the variance of r(k) is (1/n)·Σⱼ ρ_rr(j)·ρ_xx(j) (Bartlett),
    which stays honest when both are low-passed (strongly autocorrelated).

    Returns
    -------
    CrossCorrelation
    """
    r = np.asarray(residual, float) - np.mean(residual)
    u = np.asarray(x, float) - np.mean(x)
    n = len(r)
    denom = np.sqrt(np.sum(r * r) * np.sum(u * u))
    f = np.fft.rfft(r, 2 * n) * np.conj(np.fft.rfft(u, 2 * n))
    cc = np.fft.irfft(f)
    lags = np.arange(-max_lag, max_lag + 1)
    ccf = cc[lags % (2 * n)] / denom if denom > 0 else np.zeros(len(lags))
    m = min(n - 1, 4 * max_lag)
    rho_r, rho_x = autocorrelation(r, m), autocorrelation(u, m)
    var = (1.0 + 2.0 * np.sum(rho_r[1:] * rho_x[1:])) / n
    bound = _z(level) * np.sqrt(max(var, 1.0 / n))
    k = int(np.argmax(np.abs(ccf)))
    return CrossCorrelation(lags_s=lags * sample_period, ccf=ccf, bound=float(bound),
                            peak_lag_s=float(lags[k] * sample_period), peak=float(ccf[k]),
                            significant=bool(abs(ccf[k]) > bound), level=level)


def spectrum(residual: np.ndarray, torque: np.ndarray, angle: np.ndarray, fs: float, *,
             max_hz: float | None = None, level: float = 0.95, segment_s: float | None = None) -> Spectrum:
    """Residual spectrum against the torque's, and the residual's coherence with the angle.

    Welch estimates with Hann segments of ``segment_s`` (default: 8 s or a quarter of the
    record) and half overlap. A coherence above ``bound`` = 1 − (1 − level)^(1/(K − 1)) (K
    independent segments) is significant: the residual there is linear in the input (an
    unmodelled *linear* dynamics — a delay, an inertia or damping error), while a residual
    without coherence is nonlinear in it or unrelated.

    Returns
    -------
    Spectrum
        Up to ``max_hz``.
    """
    n = len(residual)
    seg = int(min(n // 4 if segment_s is None else n, (segment_s or 8.0) * fs))
    seg = max(seg, 16)
    kw = dict(fs=fs, nperseg=seg, noverlap=seg // 2, window="hann")
    f, pr = sps.welch(residual, **kw)
    _, pt = sps.welch(torque, **kw)
    _, coh = sps.coherence(residual, angle, **kw)
    segments = max(2, int((n - seg) // (seg // 2) + 1))
    k_eff = max(2.0, segments / 1.9)          # half-overlapped Hann segments ≈ K/1.9 independent ones
    bound = 1.0 - (1.0 - level) ** (1.0 / (k_eff - 1.0))
    keep = f <= (max_hz if max_hz is not None else f[-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(pt > 0, pr / pt, np.nan)
    return Spectrum(freq_hz=f[keep], residual_psd=pr[keep], torque_psd=pt[keep],
                    ratio=np.nan_to_num(ratio[keep], nan=0.0), coherence=coh[keep], bound=float(bound),
                    segments=segments, level=level)


def effective_fraction(x: np.ndarray, max_lag: int = 50) -> float:
    """n_eff/n of a correlated series: 1/(1 + 2·Σ ρ(k)) over positive-correlation lags (≤ 1)."""
    rho = autocorrelation(x, min(max_lag, len(x) - 1))[1:]
    cut = np.flatnonzero(rho <= 0)
    rho = rho[:cut[0]] if cut.size else rho
    return float(min(1.0, 1.0 / (1.0 + 2.0 * np.sum(rho))))


def binned_gap(residual: np.ndarray, deviation_power: float, labels: np.ndarray, names: list[str], *,
               level: float = 0.95, effective: float = 1.0, edges: list | None = None) -> list[Bin]:
    """The gap within each bin of an operating regime.

    Parameters
    ----------
    residual : ndarray, shape (n,)
    deviation_power : float
        Mean squared deviation of the torque from its mean over the whole record, (N·m)².
    labels : ndarray of int, shape (n,)
        Bin of each sample (−1: none).
    names : list of str
        Name of each bin.
    effective : float
        n_eff/n of the squared residual (its correlation), for the interval.
    edges : list of (lo, hi), optional
        Range of each bin, reported.

    Returns
    -------
    list of Bin
        One per name; the interval is χ² with n_eff degrees of freedom (the mean of n_eff
        squared Gaussian residuals).
    """
    r2 = np.asarray(residual, float) ** 2
    overall = float(np.mean(r2)) if r2.size else float("nan")
    out = []
    for k, name in enumerate(names):
        sel = labels == k
        n = int(sel.sum())
        span = None if edges is None else tuple(float(v) for v in edges[k])
        share = n / max(len(r2), 1)
        if n == 0 or not overall > 0:
            out.append(Bin(name, span, n, share))
            continue
        mean = float(np.mean(r2[sel]))
        dof = max(1.0, n * effective)
        lo = mean * dof / stats.chi2.ppf(0.5 + level / 2, dof)
        hi = mean * dof / stats.chi2.ppf(0.5 - level / 2, dof)
        out.append(Bin(name, span, n, share, gap=mean / deviation_power, ratio=mean / overall,
                       interval=(lo / overall, hi / overall)))
    return out


def quantile_bins(x: np.ndarray, k: int) -> tuple[np.ndarray, list]:
    """Labels (n,) of k equally populated bins of x, and their (lo, hi) ranges."""
    edges = np.quantile(x, np.linspace(0, 1, k + 1))
    labels = np.clip(np.searchsorted(edges[1:-1], x, side="right"), 0, k - 1)
    return labels, [(edges[i], edges[i + 1]) for i in range(k)]


def speed_bins(velocity: np.ndarray, still: float, k: int = 4) -> tuple[np.ndarray, list, list]:
    """Bin 0 'near zero' (|ẏ| ≤ ``still``), then k equally populated bins of the faster samples."""
    speed = np.abs(velocity)
    labels = np.full(len(speed), 0)
    moving = speed > still
    names, ranges = [f"near zero (|v| ≤ {still:.3g})"], [(0.0, still)]
    if np.any(moving):
        lab, rng = quantile_bins(speed[moving], k)
        labels[moving] = lab + 1
        names += [f"|v| {lo:.3g}–{hi:.3g}" for lo, hi in rng]
        ranges += rng
    return labels, names, ranges


def reversal_mask(velocity: np.ndarray, half_width: int, still: float = 0.0) -> np.ndarray:
    """Samples within ``half_width`` samples of a reversal (a sign change of ẏ beyond ±still)."""
    v = np.asarray(velocity, float)
    s = np.sign(np.where(np.abs(v) > still, v, 0.0))
    nz = np.flatnonzero(s)
    mask = np.zeros(len(v), dtype=bool)
    if nz.size < 2:
        return mask
    flips = nz[1:][s[nz[1:]] != s[nz[:-1]]]
    prev = nz[:-1][s[nz[1:]] != s[nz[:-1]]]
    for a, b in zip(prev, flips):
        mask[max(0, a - half_width):min(len(v), b + half_width + 1)] = True
    return mask


def change_points(values: np.ndarray, *, penalty: float | None = None, min_size: int = 2) -> list[int]:
    """Mean-shift change points of a series by binary segmentation.

    A split is kept when it lowers the sum of squared deviations by more than ``penalty``
    (default: 2·σ²·ln n, the Schwarz criterion, with σ estimated robustly from first
    differences: MAD/√2).

    Returns
    -------
    list of int
        Indices where a new segment starts, ascending.
    """
    x = np.asarray(values, float)
    n = len(x)
    if n < 2 * min_size:
        return []
    if penalty is None:
        d = np.diff(x)
        sigma = robust_sd(d) / np.sqrt(2.0)
        penalty = 2.0 * max(sigma, 1e-12) ** 2 * np.log(n)
    found = []

    def split(lo, hi):
        seg = x[lo:hi]
        m = len(seg)
        if m < 2 * min_size:
            return
        c = np.cumsum(seg)
        total = c[-1]
        k = np.arange(min_size, m - min_size + 1)
        left = c[k - 1]
        gain = left ** 2 / k + (total - left) ** 2 / (m - k) - total ** 2 / m
        j = int(np.argmax(gain))
        if gain[j] > penalty:
            cut = lo + int(k[j])
            found.append(cut)
            split(lo, cut)
            split(cut, hi)

    split(0, n)
    return sorted(found)
