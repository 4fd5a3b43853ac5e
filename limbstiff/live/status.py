"""The live terminal line of ``limbstiff stream``: what the estimate is doing now, in one line."""

from __future__ import annotations

import numpy as np

from .checks import REASONS


def status_line(session, *, stalled_s: float | None = None, ended: bool = False) -> str:
    """One line: record length, the last stiffness and band, the live checks (the failed ones' names,
    and what the first means in plain words: :data:`~limbstiff.live.checks.REASONS`), m and b, the
    stream's state.

    Parameters
    ----------
    session : LiveSession
    stalled_s : float, optional, s
        Time since the last sample, when the stream has stalled.
    ended : bool
        Its sender has closed the stream (said instead of ``STALLED``).

    Returns
    -------
    str
    """
    ev = session.events
    seconds = ev.samples / session.fs
    parts = [f"{seconds:7.1f} s"]
    last = session.last
    if session.model is None:
        pending = session.pending is not None
        parts.append("identifying m, b and the noise…" if pending else
                     f"warming up ({seconds:.0f}/{session.warmup_s:g} s)")
    elif last is not None and np.isfinite(last[0]):
        parts.append(f"stiffness {last[0]:.4g} [{last[1]:.4g}, {last[2]:.4g}]")
        m = session.model
        if m.inertia or m.damping:          # none for the direct variant
            parts.append(f"m {m.inertia:.3g} b {m.damping:.3g}")
    checks = session.checks
    if checks is not None:
        if np.isfinite(checks.motion):
            parts.append(f"informed {100 * checks.motion:.0f} %")
        if np.isfinite(checks.explained):
            parts.append(f"explained {100 * checks.explained:.1f} %")
        parts.append(f"verdict {checks.verdict.value}" + (f" ({', '.join(checks.failed)}: {REASONS[checks.failed[0]]})"
                                                          if checks.failed else ""))
    if ev.dropped_samples:
        parts.append(f"dropped {ev.dropped_samples}")
    if ev.breaks:
        parts.append(f"breaks {len(ev.breaks)}")
    if ev.identifications and "error" in ev.identifications[-1]:      # until one succeeds
        parts.append(f"identification failed: {ev.identifications[-1]['error']}")
    if stalled_s is not None:
        parts.append(f"stream ended {stalled_s:.0f} s ago" if ended else f"STALLED {stalled_s:.0f} s")
    return " | ".join(parts)
