"""The answer of one analysis in words: what page 1 of the report says and what
:meth:`StiffnessResult.report` prints.

Plain functions of a :class:`~limbstiff.result.StiffnessResult` returning strings and
``(label, text)`` rows; no drawing here (the report draws the same rows on its first page).
"""

from __future__ import annotations

import textwrap

import numpy as np

from .interval import Interval

#: How each verdict reads, and its colour on page 1.
VERDICT_WORDS = {
    "ok": ("OK", "the model fits this recording: the stiffness can be used", "#1a7f37"),
    "caution": ("CAUTION", "the model misses part of this recording: the stiffness may be biased", "#b35c00"),
    "unreliable": ("UNRELIABLE", "the model does not fit this recording: do not use the stiffness", "#c62828"),
}
#: How the ``angle_dependence`` check's message begins when the stiffness follows the angle within
#: the cycle, well determined (:func:`limbstiff.checks.analysis._angle_dependence`): the verdict
#: then says what it is instead of a misfit.
ANGLE_PROPERTY = "the joint's stiffness depends on its angle"
#: The verdict's words when that is its only reason.
ANGLE_VERDICT = "the stiffness varies with the angle within each cycle (see below)"
#: Metadata lines on page 1 at most (the rest is in summary.json).
METADATA_LINES = 6


def number(x, unit: str = "", digits: int = 4) -> str:
    """A number with its unit, ``—`` when missing or not finite."""
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "—"
    return f"{x:.{digits}g} {unit}".strip()


def interval_text(v: Interval | None, unit: str) -> str:
    """``median unit [lo, hi]``; ``—`` when missing."""
    if v is None or v.median is None:
        return "—"
    if v.is_fixed:
        return number(v.median, unit)
    return f"{number(v.median, unit)}  [{number(v.lo)}, {number(v.hi)}]"


def verdict_line(result) -> tuple[str, str, str] | None:
    """(word, meaning, colour) of the result's verdict; None when no check was run. A ``caution``
    whose only reason is the stiffness depending on the angle (:data:`ANGLE_PROPERTY`) says so
    (:data:`ANGLE_VERDICT`), not that the model misses part of the recording."""
    if result.checks is None:
        return None
    word, meaning, colour = VERDICT_WORDS[result.checks.verdict]
    failed = result.checks.failed
    if failed and all(c.name == "angle_dependence" and c.message.startswith(ANGLE_PROPERTY) for c in failed):
        meaning = ANGLE_VERDICT
    return word, meaning, colour


def headline_rows(result) -> list[tuple[str, str]]:
    """(label, text) of the trial's figures, each with what its interval is.

    The stiffness figures come first (median, at mean torque, slope against torque, range),
    then inertia and damping, the informed share and, for simulated trials, the error against
    the true stiffness.
    """
    u, pct = result.trial.units, f"{100 * result.ci_level:.0f} %"
    median, low, high = result.informed_stiffness()
    level = result.trial_level
    joint = level is not None and np.isfinite(median.lo)
    angle = joint and "angle" in level.sources and _failed(result, "angle_dependence")
    rows = [("Median stiffness", interval_text(median, u["stiffness"])
             + (f"  — {pct} interval of the median over the informed samples" if joint else
                f"  — medians of the per-sample {pct} band (no joint uncertainty for this estimator)")
             + ("; with the stiffness's change with the angle within the cycle, which the course averages"
                if angle else ""))]
    if joint:
        slope_unit = f"({u['stiffness']})/({u['torque']})" if "torque" in u else ""
        rows += [("Stiffness at mean torque", interval_text(level.stiffness_at_mean_torque, u["stiffness"])
                  + f"  — {pct} interval, from the line of stiffness against background torque"),
                 ("Stiffness vs torque", interval_text(level.stiffness_torque_slope, slope_unit)
                  + f"  — that line's slope, {pct} interval")]
    where = "informed samples" if result.observable.any() else "all samples: none is informed"
    rows.append(("Stiffness range", f"{number(low)} to {number(high, u['stiffness'])} over the trial ({where})"))
    rows += [(name.capitalize(), mechanics_text(result, name)) for name in ("inertia", "damping")]
    rows += [(f"In the model: {e.name}", effect_text(e, pct)) for e in
             (() if result.identification is None else result.identification.effects)]
    rows.append(("Informed by motion", f"{100 * result.observable_fraction:.1f} % of the trial"))
    err = result.reference_error()
    if err and err.get("median") is not None:
        rows.append(("Error vs reference", f"median {100 * err['median']:.2f} %, 90th percentile "
                                           f"{100 * err['p90']:.2f} %; the band holds it at "
                                           f"{100 * err['coverage']:.0f} % of the samples"))
    return rows


def _failed(result, name: str) -> bool:
    """Whether the check ``name`` ran and failed."""
    return result.checks is not None and any(c.name == name for c in result.checks.failed)


def shape_text(shape) -> str:
    """An effect's shape parameters in words: delays in ms, the rest to 3 digits."""
    return ", ".join(f"{k} {'none' if v is None else (f'{1e3 * v:.0f} ms' if k == 'delay' else f'{v:.3g}')}"
                     for k, v in shape.items())


def effect_text(effect, pct: str) -> str:
    """The line of an effect put in the model (``--effect``): amplitude, interval and shape."""
    shape = shape_text(effect.shape)
    return (f"{effect.amplitude_name} {interval_text(effect.amplitude, effect.unit)}  — {pct} interval, identified "
            f"with m and b" + (f"; {shape}" if shape else ""))


def mechanics_text(result, name: str) -> str:
    """The line for ``inertia`` or ``damping``: interval, given value or not needed."""
    value, unit = getattr(result, name), result.trial.units[name]
    ident = result.identification
    if value is None:
        return "not needed (the elastic torque is measured)"
    if (ident is not None and ident.given) or value.is_fixed:
        text = f"{number(value.median, unit)} (given, not identified)"
    else:
        text = interval_text(value, unit) + f"  — {100 * result.ci_level:.0f} % interval, identified"
    expected = None if ident is None else ident.expected_inertia
    if name == "inertia" and expected:
        lo, hi = expected
        text += f"; {'within' if ident.inertia_in_expected_range else 'OUTSIDE'} the expected {lo:g}–{hi:g}"
    return text


def recording_rows(result, *, lines: int = METADATA_LINES) -> list[tuple[str, str]]:
    """A short table of what was analysed: the file, sampling, and the first metadata entries."""
    trial = result.trial
    rows = [("Source", trial.source or "(in memory)"),
            ("Recording", f"{trial.duration:.4g} s at {trial.fs:.4g} Hz ({trial.n_samples} samples)")]
    meta = list(trial.metadata.items())
    room = max(lines - len(rows), 0)
    shown = meta if len(meta) <= room else meta[:max(room - 1, 0)]
    rows += [(str(k), textwrap.shorten(str(v), 60)) for k, v in shown]
    if len(shown) < len(meta):
        rows.append(("…", f"{len(meta) - len(shown)} more entries in summary.json"))
    return rows


def text_report(result, *, width: int = 100) -> str:
    """What page 1 of the report says, as plain text.

    Parameters
    ----------
    result : StiffnessResult
    width : int
        Characters per line.
    """
    head = f"Stiffness of trial {result.trial.name}"
    lines = [head, "=" * len(head)]
    verdict = verdict_line(result)
    if verdict is not None:
        lines.append(f"Verdict: {verdict[0]} — {verdict[1]}")
        lines += [textwrap.fill(r, width, initial_indent="  - ", subsequent_indent="    ")
                  for r in result.checks.reasons]
    lines.append("")
    rows = headline_rows(result) + [("Warnings", w) for w in result.warnings] + recording_rows(result)
    key = max(len(label) for label, _ in rows) + 2
    for label, text in rows:
        lines.append(textwrap.fill(text, width, initial_indent=f"{label:<{key}}",
                                   subsequent_indent=" " * key))
    return "\n".join(lines)
