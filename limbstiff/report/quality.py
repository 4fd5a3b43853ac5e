"""The data-quality page of the per-trial report: sampling, the filter bandwidth against the
spectra, quantisation against the signal, the observer's settings and the MCMC diagnostics.
"""

from __future__ import annotations

import numpy as np

from ..digest import INFORMED_GLOSS
from .common import FONT, fmt, grid, is_constant, new_page, text_panel
from .plots import names, recorded_torque


#: Segments of the spectrum's Welch average transformed at once (a few MB, whatever the length).
SPECTRUM_SEGMENTS = 128
#: Samples of the signal the trend's slope is summed over at once.
SPECTRUM_BLOCK = 1 << 18


def spectrum(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectral density of a detrended signal (Welch, as the bandwidth choice uses).

    The same as :func:`limbstiff.signals.welch_spectrum` (the whole signal's linear trend removed,
    Hann segments of 4 s rounded up to a power of two, half overlapping, each less its mean), to
    rounding, but taken over blocks of :data:`SPECTRUM_SEGMENTS` segments: neither a detrended copy
    of the signal nor all its segments exist at once, which on a one-hour trial is 150 MB less.

    Parameters
    ----------
    x : ndarray, shape (n,)
    fs : float, Hz

    Returns
    -------
    freq : ndarray, Hz
    asd : ndarray, unit of x per √Hz
    """
    from scipy import signal
    x = np.asarray(x, dtype=float)
    n = x.size
    length = int(min(n, max(256, 2 ** np.ceil(np.log2(4.0 * fs)))))
    step = length - length // 2
    starts = np.arange(0, n - length + 1, step)
    window = signal.get_window("hann", length)
    # after each segment's mean is taken off, only the trend's slope is left of it (scipy's detrend)
    ramp = _trend_slope(x) * (np.arange(length) - (length - 1) / 2)
    total = np.zeros(length // 2 + 1)
    segments = np.lib.stride_tricks.sliding_window_view(x, length)[::step]
    for first in range(0, len(starts), SPECTRUM_SEGMENTS):
        block = segments[first:first + SPECTRUM_SEGMENTS] - ramp
        block -= block.mean(axis=1, keepdims=True)
        block *= window
        total += (np.abs(np.fft.rfft(block, axis=1)) ** 2).sum(axis=0)
    psd = total / (len(starts) * fs * np.sum(window ** 2))
    psd[1:-1 if length % 2 == 0 else None] *= 2
    return np.fft.rfftfreq(length, 1 / fs), np.sqrt(psd)


def _trend_slope(x: np.ndarray) -> float:
    """The least-squares slope of ``x`` against its sample index, summed in blocks."""
    n = x.size
    centre = (n - 1) / 2
    moment = sum(float(np.dot(np.arange(at, min(at + SPECTRUM_BLOCK, n)) - centre, x[at:at + SPECTRUM_BLOCK]))
                 for at in range(0, n, SPECTRUM_BLOCK))
    return moment / (n * (n * n - 1.0) / 12.0) if n > 1 else 0.0


def _spectrum_axes(fig, where, x, fs, *, label, unit, cutoff, edge, step, floor=None):
    """The spectrum of ``x`` against the filter's corner and the noise levels in the grid cell
    ``where``; the axes, or None when there is no spectrum (said in words there instead)."""
    if is_constant(x):
        text_panel(fig, where, f"The {label} is constant ({fmt(float(np.mean(x)), unit)}): it has no spectrum.")
        return None
    freq, asd = spectrum(x, fs)
    keep = (freq > 0) & (asd > 0)
    if keep.sum() < 2:
        text_panel(fig, where, f"The {label} has no spectrum to show (too short or a straight line).")
        return None
    from matplotlib.ticker import FuncFormatter, NullLocator
    ax = fig.add_subplot(where)
    ax.loglog(freq[keep], asd[keep], lw=0.8, color="C0", label=f"{label} spectrum")
    for axis in (ax.xaxis, ax.yaxis):
        # a log axis's minor ticks and math-text labels cost more than the page's data
        axis.set_minor_locator(NullLocator())
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    if cutoff is not None:
        ax.axvline(cutoff, color="C3", lw=1.2, label=f"low-pass corner {cutoff:.3g} Hz")
    if edge:
        ax.axvline(edge, color="C1", lw=1, ls="--", label=f"signal edge {edge:.3g} Hz")
    if floor:
        ax.axhline(np.sqrt(floor), color="0.4", lw=0.8, ls=":", label="noise floor")
    if step:
        ax.axhline(step / np.sqrt(6 * fs), color="C2", lw=0.8, ls="-.", label="quantisation noise q/sqrt(6 fs)")
    ax.set_xlim(freq[keep][0], fs / 2)
    bottom = np.percentile(asd[keep], 0.5)
    ax.set_ylim(bottom / 3, asd[keep].max() * 3)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"{label} ASD [{unit}/sqrt(Hz)]")
    ax.legend(loc="lower left", fontsize=FONT["small"], framealpha=0.85)
    return ax


def _scan_axes(fig, where, ax, scan, fs) -> None:
    """The model's held-out torque prediction at each corner tried, on a second y axis of the
    torque spectrum's panel ``ax`` (same frequency axis) in the grid cell ``where``; on an axes of
    its own there, without the frequency axis, when the torque has no spectrum (``ax`` None)."""
    if scan is None:
        return
    pairs = [(fs / 2 * 0.95 if c is None else c, v) for c, v in zip(scan.corners_hz, scan.scores) if v is not None]
    if not pairs:
        return
    twin = ax.twinx() if ax is not None else _right_axis(fig.add_subplot(where))
    corners, scores = map(np.asarray, zip(*pairs))
    twin.plot(corners, 100 * np.clip(scores, -1, 1), "o-", color="C4", ms=3.5, lw=1,
              label="torque predicted out of sample, per corner tried")
    chosen = fs / 2 * 0.95 if scan.chosen_hz is None else scan.chosen_hz
    twin.plot([chosen], [100 * dict(pairs).get(chosen, np.nan)], "*", color="C3", ms=11, label="corner kept")
    twin.set_ylim(min(0.0, 100 * float(scores.min()) - 5), 100)
    twin.set_ylabel("held-out torque predicted [%]", color="C4")
    # one legend for both y axes (drawn on the twin, which lies on top)
    handles, labels = ax.get_legend_handles_labels() if ax is not None else ([], [])
    more, more_labels = twin.get_legend_handles_labels()
    if ax is not None and ax.get_legend() is not None:
        ax.get_legend().remove()
    twin.legend(handles + more, labels + more_labels, loc="lower left", ncols=2, fontsize=FONT["small"],
                framealpha=0.85)


def _right_axis(ax):
    """``ax`` drawn as the twin of a panel without axes would be: its y axis on the right, no x axis."""
    ax.yaxis.tick_right()
    ax.yaxis.set_label_position("right")
    ax.xaxis.set_visible(False)
    ax.patch.set_visible(False)
    return ax


def _rms(x) -> float:
    """RMS about the mean (0 for a constant signal, whatever its round-off)."""
    return 0.0 if is_constant(x) else float(np.std(np.asarray(x, float)))


def _quantisation_rows(label, unit, step, x):
    rms = _rms(x)
    rows = [(f"{label} step", f"{fmt(step, unit)}" if step else "none found (continuous)"),
            (f"{label} RMS", fmt(rms, unit))]
    if step and rms > 0:
        rows.append(("  step / RMS", f"{100 * step / rms:.3g} % ({np.log2(rms / step):.1f} bits over the RMS)"))
    return rows


def _mcmc_rows(result):
    ident = result.identification
    if ident is None or ident.posterior is None:
        why = "direct variant" if result.variant == "direct" else "inertia and damping given"
        return f"No MCMC was run ({why})."
    mcmc = ident.posterior.diagnostics
    rows = [("sampler", f"emcee, seed {mcmc.seed}"),
            ("walkers × steps", f"{mcmc.n_walkers} × {mcmc.n_steps} (burn-in {mcmc.burn_in}, thin {mcmc.thin})"),
            ("moves", (f"{100 * mcmc.independence_share:.0f} % independence t, the rest DE"
                       if mcmc.independence_share else "differential evolution (DE)")
             + f"; {mcmc.adaptation_steps} steps before, discarded")]
    for name, tau in mcmc.autocorr_time.items():
        short = {"log_measurement": "tau ln R", "log_torque_walk": "tau ln Q_s",
                 "log_stiffness_walk": "tau ln Q_sigma", "log_coupled_walk": "tau ln Q_c"}.get(name, f"tau {name}")
        rows.append((short, f"{fmt(tau, 'steps', 3)}"))
    rows += [("chain / tau", f"{fmt(mcmc.chain_in_autocorr_times, '', 3)} (50 or more wanted)"),
             ("acceptance", f"{fmt(mcmc.acceptance_fraction, '', 3)}"),
             ("converged", "yes" if mcmc.converged else "NO: chain shorter than 50 tau"),
             ("decimation", f"{ident.decimation} samples per filter step")]
    return rows


def quality_page(result):
    """Data quality: sampling, bandwidth, quantisation, observer settings, MCMC diagnostics."""
    trial, f, d = result.trial, result.filtered, result.derived
    u, word = trial.units, names(trial)
    bw = f.bandwidth
    key, torque = recorded_torque(result)
    fig = new_page("Data quality")
    gs = grid(fig, 4, 2, height_ratios=[0.85, 1.2, 1.2, 1.05], hspace=0.35, wspace=0.25)
    sampling = [("rate", f"{trial.fs:.6g} Hz (step {1e3 * trial.sample_period:.4g} ms)"),
                ("samples", f"{trial.n_samples} over {trial.duration:.4g} s")]
    reading = [w for w in trial.warnings] or ["none"]
    sampling += [("reading notes" if i == 0 else "", w) for i, w in enumerate(reading)]
    text_panel(fig, gs[0, 0], sampling, title="Sampling", key_width=0.3, wrap=42,
               fontsize=FONT["small"])
    cutoff = bw.cutoff_hz
    chain = f.chain.kind
    filt = "paper's causal chain (Sec. V)" if chain == "paper" else (
        f"zero-phase Butterworth, corner {cutoff:.4g} Hz" if cutoff else "none (signal edge above fs/4)")
    observer = [("derivatives", filt),
                ("signal edge", fmt(bw.signal_edge_hz, "Hz")),
                ("motion frequency", fmt(f.motion_hz, "Hz")),
                ("range of motion", fmt(d.range_of_motion, u["angle"])),
                ("observer gain", f"{fmt(d.observer_gain, '1/' + u['angle'])} "
                                    f"(memory {fmt(d.observer_memory, u['angle'], 3)})"),
                ("informed window", f"{fmt(d.observable_window_s, 's', 3)}; speed above "
                                    f"{fmt(d.velocity_threshold, u['angle'] + '/s', 3)}"),
                ("informed", f"{100 * result.observable_fraction:.1f} % of the samples: "
                             + INFORMED_GLOSS.partition(": ")[2])]
    text_panel(fig, gs[0, 1], observer, title="Filter and observer", key_width=0.36, wrap=36,
               fontsize=FONT["small"])
    edge = bw.signal_edge_hz
    _spectrum_axes(fig, gs[1, :], trial.angle, trial.fs, label=word["angle"], unit=u["angle"],
                   cutoff=cutoff, edge=edge, step=bw.quantisation_step, floor=bw.noise_floor)
    torque_axes = _spectrum_axes(fig, gs[2, :], torque, trial.fs, label=word[key], unit=u[key],
                                 cutoff=cutoff, edge=edge, step=f.torque_quantisation_step)
    _scan_axes(fig, gs[2, :], torque_axes, result.corner_scan, trial.fs)
    quant = (_quantisation_rows(word["angle"], u["angle"], bw.quantisation_step, trial.angle)
             + _quantisation_rows(word[key], u[key], f.torque_quantisation_step, torque))
    text_panel(fig, gs[3, 0], quant, title="Quantisation", key_width=0.36, wrap=36,
               fontsize=FONT["small"])
    text_panel(fig, gs[3, 1], _mcmc_rows(result), title="MCMC (inertia, damping)", key_width=0.36,
               wrap=36, fontsize=FONT["small"])
    return fig
