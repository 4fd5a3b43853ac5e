"""Per-trial PDF stiffness report. The only module that imports matplotlib, and only when
a report is made (non-interactive Agg backend).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import __version__
from ..io.atomic import atomic_output

A4 = (8.27, 11.69)


def _fmt(x, unit=""):
    return "—" if x is None else f"{x:.4g} {unit}".strip()


def _shade_unobservable(ax, time, observable):
    edges = np.diff(np.concatenate([[0], (~observable).astype(int), [0]]))
    for lo, hi in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        ax.axvspan(time[lo], time[hi - 1], color="0.85", lw=0, zorder=0)


def _first_page(fig, result):
    s = result.summary()
    u = s["units"]
    lines = [
        ("Trial", s["trial"]),
        ("Source", s["source"] or "(in memory)"),
        ("Variant / estimator", f"{s['variant']} / {s['estimator']}"),
        ("Sampling", f"{s['fs_hz']:.4g} Hz, {s['n_samples']} samples, {s['duration_s']:.4g} s"),
        ("Median stiffness", f"{_fmt(s['stiffness']['median'], u['stiffness'])} "
                             f"[{_fmt(s['stiffness']['lo'])}, {_fmt(s['stiffness']['hi'])}] "
                             f"({100 * s['ci_level']:.0f} % band)"),
        ("Stiffness range", f"{_fmt(s['stiffness']['min'])} to {_fmt(s['stiffness']['max'], u['stiffness'])}"),
    ]
    expected = ((s["details"].get("identification") or {}).get("inertia_in_expected_range"))
    for name in ("inertia", "damping"):
        v = s[name]
        text = "not needed (direct variant)" if v is None else \
            f"{_fmt(v['median'], u[name])} [{_fmt(v['lo'])}, {_fmt(v['hi'])}]"
        if name == "inertia" and expected:
            lo, hi = expected["range"]
            text += f" — {'within' if expected['inside'] else 'OUTSIDE'} the expected {lo:g}–{hi:g}"
        lines.append((name.capitalize(), text))
    lines.append(("Observable fraction", f"{100 * s['observable_fraction']:.1f} % of the trial"))
    err = s.get("reference_error")
    if err and err.get("median") is not None:
        lines.append(("Error vs reference", f"median {100 * err['median']:.2f} %, "
                                            f"90th percentile {100 * err['p90']:.2f} %"))
    fig.text(0.08, 0.95, f"Stiffness report — {s['trial']}", fontsize=16, weight="bold")
    y = 0.90
    for label, value in lines:
        fig.text(0.08, y, label, fontsize=10, weight="bold")
        fig.text(0.38, y, value, fontsize=10, wrap=True)
        y -= 0.028
    y -= 0.01
    fig.text(0.08, y, "Warnings", fontsize=11, weight="bold")
    for w in s["warnings"] or ["none"]:
        y -= 0.026
        fig.text(0.10, y, f"• {w}", fontsize=9, wrap=True)
    # the file's own metadata (subject, side, date…); long machine-written lists are cut
    meta = list(s["metadata"].items())
    if meta:
        y -= 0.04
        fig.text(0.08, y, "Metadata", fontsize=11, weight="bold")
        room = max(0, int((y - 0.06) / 0.022))
        for key, value in meta[:room]:
            y -= 0.022
            fig.text(0.10, y, f"{key}: {value}", fontsize=8)
        if len(meta) > room:
            fig.text(0.10, y - 0.022, f"… {len(meta) - room} more in summary.json", fontsize=8, style="italic")
    _footer(fig, s)


def _footer(fig, s):
    fig.text(0.08, 0.02, f"limbstiff {__version__} · seed {s['seed']} · source sha256 "
                         f"{(s['source_sha256'] or '—')[:16]}…", fontsize=7, color="0.4")


def _figures_page(fig, result):
    trial, u = result.trial, result.trial.units
    t = trial.time
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(t, trial.angle, lw=0.6)
    axes[0].set_ylabel(f"angle [{u['angle']}]")
    torque = trial.torque if trial.torque is not None else trial.elastic_torque
    axes[1].plot(t, torque, lw=0.6, color="C1")
    axes[1].set_ylabel(f"torque [{u['torque']}]")
    ax = axes[2]
    _shade_unobservable(ax, t, result.observable)
    ax.fill_between(t, result.stiffness_lo, result.stiffness_hi, color="C0", alpha=0.3, lw=0,
                    label=f"{100 * result.ci_level:.0f} % band")
    ax.plot(t, result.stiffness, lw=0.8, color="C0", label="estimate")
    if result.reference is not None:
        ax.plot(t, result.reference, lw=0.8, color="k", ls="--", label="reference")
    obs = result.stiffness[result.observable] if result.observable.any() else result.stiffness
    lo, hi = np.percentile(obs, [1, 99])
    pad = 0.2 * (hi - lo) + 1e-12
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("grey: not informed by motion", fontsize=8, loc="right")
    fig.tight_layout(rect=(0, 0.03, 1, 1))


def _scatter_page(fig, result):
    trial, u = result.trial, result.trial.units
    obs = result.observable
    axes = fig.subplots(2, 1)
    torque = trial.torque if trial.torque is not None else trial.elastic_torque
    for ax, x, label in ((axes[0], trial.angle, f"angle [{u['angle']}]"),
                         (axes[1], torque, f"torque [{u['torque']}]")):
        ax.plot(x[obs], result.stiffness[obs], ".", ms=1, alpha=0.4)
        ax.set_xlabel(label)
        ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    fig.tight_layout(rect=(0, 0.03, 1, 1))


def write_report(result, path: str | Path) -> None:
    """Write the PDF report of one :class:`~limbstiff.result.StiffnessResult`, atomically.

    Parameters
    ----------
    result : StiffnessResult
    path : str or Path
    """
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    metadata = {"Title": f"limbstiff stiffness report: {result.trial.name}",
                "Creator": f"limbstiff {__version__}", "Subject": result.trial.source or result.trial.name}
    with atomic_output(path) as tmp:
        with PdfPages(tmp, metadata=metadata) as pdf:
            for page in (_first_page, _figures_page, _scatter_page):
                fig = Figure(figsize=A4)
                page(fig, result)
                pdf.savefig(fig)
