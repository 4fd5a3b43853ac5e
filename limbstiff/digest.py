"""The answer of one analysis in words: what page 1 of the report says and what
:meth:`StiffnessResult.report` prints.

Plain functions of a :class:`~limbstiff.result.StiffnessResult` returning strings and
``(label, text)`` rows; no drawing here (the report draws the same rows on its first page).
"""

from __future__ import annotations

import textwrap
from typing import NamedTuple

import numpy as np

from .interval import Interval
from .trial_level import BACKGROUND_PERIODS

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
#: The words a reader may not know, in plain words: a one-line gloss where they appear.
INFORMED_GLOSS = "informed: the samples where the motion lets the data say what the stiffness is"
BACKGROUND_GLOSS = (f"background torque: the torque the joint holds on average (over {BACKGROUND_PERIODS:g} "
                    "periods of the motion)")


class CycleCourse(NamedTuple):
    """The stiffness course at the resolution the data support: one value per motion cycle
    (:func:`cycle_course`). Arrays of shape (k,), one entry per cycle.

    Parameters
    ----------
    time : ndarray, s
        Middle of the cycle.
    stiffness : ndarray, N·m/rad (N/m)
        Median over the cycle's informed samples of the course the headline median is taken over
        (NaN for an uninformed cycle; over all samples when none of the trial is informed).
    lo, hi : ndarray, N·m/rad (N/m)
        Medians of the band's bounds over those samples, moved with that course: the per-sample
        band, typical for the cycle.
    informed : ndarray of bool
        At least half of the cycle's samples informed by motion (and clear of the filter's edges).
    seconds : float, s
        Length of a cycle (of the bins).
    """

    time: np.ndarray
    stiffness: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    informed: np.ndarray
    seconds: float


def _bin_samples(result) -> int:
    """Samples per bin of :func:`cycle_course`: one motion period, in whole Kalman steps (one
    sample per step for the observers), one step at least."""
    step = int(getattr(result.fit, "decimation", None) or 1)
    motion_hz = getattr(result.filtered, "motion_hz", None)
    if motion_hz is None or not np.isfinite(motion_hz) or motion_hz <= 0:
        return step
    return step * max(1, int(round(result.trial.fs / motion_hz / step)))


def _course_samples(result) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The samples :func:`cycle_course` bins and their values: the course the trial-level figures
    (the headline median among them) are taken over, at their samples, with the band moved with it
    (:attr:`~limbstiff.trial_level.TrialLevel.course`); without one every sample of the estimate,
    the filter's edge samples left out. Returns sample index, course, band's bounds and the
    samples used, each shape (c,)."""
    level = getattr(result, "trial_level", None)
    if level is not None and level.course is not None:
        index, course = level.index, level.course
        shift = course - result.stiffness[index]
        return index, course, result.stiffness_lo[index] + shift, result.stiffness_hi[index] + shift, level.informed
    n = result.stiffness.size
    use = np.asarray(result.observable, bool).copy()
    edge = int(getattr(result.filtered, "edge", 0) or 0)
    if edge:
        use[:edge] = use[n - edge:] = False
    return np.arange(n), result.stiffness, result.stiffness_lo, result.stiffness_hi, use


def cycle_course(result) -> CycleCourse:
    """The stiffness course binned to one period of the trial's motion, over its informed samples.

    Why one motion period: the stiffness is the slope of torque against angle, and the angle sweeps
    its range once per period; within a period the data hold one slope. The Kalman smoother's
    course, sample by sample, moves faster than that wherever the model takes up torque it cannot
    explain (a reflex, a resonance) as stiffness changes: on the real ankle trial ``z_pf`` it swings
    from −100 to +200 N·m/rad within a second while its per-sample band is 120 N·m/rad wide. The
    stiffness walk of the model has no time constant of its own to bin to, so the motion's period
    is the finest resolution a reader can trust; a course that changes over seconds (the bundled
    elbow's ramp) keeps its shape. Bins are whole Kalman steps (the smoother's own resolution).

    What is binned is what the headline's median is the median of (:func:`_course_samples`): the
    course at the trial-level figures' samples, with the stiffness's change with the angle within
    the cycle when the analysis found one, so that the headline lies within the range drawn.

    The band drawn with a cycle is the median of the per-sample band over it: the uncertainty of a
    value at one instant of the cycle, not the (narrower) one of the cycle's median, which would need
    the course's joint draws. Samples not informed by motion, and the filter's edge samples at both
    ends (the smoother's start, where the band is many times its typical width), are left out; a
    cycle with fewer than half its samples left is not informed and has no value (NaN).

    Parameters
    ----------
    result : StiffnessResult

    Returns
    -------
    CycleCourse
    """
    n = result.stiffness.size
    width = min(_bin_samples(result), n)
    index, course, lo, hi, use = _course_samples(result)
    use = np.asarray(use, bool).copy()
    anything = use.any()
    if not anything:                                    # drawn over all samples, every cycle uninformed
        use[:] = True
    starts = np.arange(0, n - width + 1, width)
    stops = np.append(starts[1:], n)                    # the rest of the trial joins the last bin
    k = starts.size
    out = np.full((3, k), np.nan)
    informed = np.zeros(k, bool)
    edges = np.append(np.searchsorted(index, starts), len(index))     # index is sorted: bins are runs of it
    for j, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        sel = use[a:b]
        informed[j] = b > a and 2 * np.count_nonzero(sel) >= b - a
        if informed[j]:
            out[:, j] = [np.median(x[a:b][sel]) for x in (course, lo, hi)]
    t = result.trial.time
    middle = 0.5 * (t[starts] + t[stops - 1])
    return CycleCourse(middle, out[0], out[1], out[2], informed & anything, width / result.trial.fs)


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
    median, _, _ = result.informed_stiffness()
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
    rows.append(("Stiffness range", range_text(result)))
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


def slope_gloss(result) -> str:
    """The slope's unit in plain words (``(N·m/rad)/(N·m): how much …``)."""
    u = result.trial.units
    return (f"({u['stiffness']})/({u['torque']}): how much the stiffness rises per {u['torque']} of "
            "background torque")


def gloss_rows(result, rows: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """The glosses of the words of ``rows`` that a reader may not know ("informed", "background
    torque", the slope's unit), as ``("", gloss)`` rows, each once and only when it appears."""
    text = " ".join(f"{label} {value}" for label, value in rows)
    glosses = [INFORMED_GLOSS] if "informed" in text.lower() else []
    if "background torque" in text:
        glosses.append(BACKGROUND_GLOSS)
        if "torque" in result.trial.units and f"({result.trial.units['torque']})" in text:
            glosses.append(slope_gloss(result))
    return [("In plain words" if k == 0 else "", g) for k, g in enumerate(glosses)]


def task_cycle_s(result) -> str | None:
    """The length of the task's cycles in words, when a curve analysis by phase cut the trial into
    cycles (:attr:`~limbstiff.curve_result.CurveAnalysis.task_cycle_s`); None otherwise."""
    curve = getattr(result, "curve", None)
    return None if curve is None else curve.task_cycle_s


def period_words(result, course: CycleCourse) -> tuple[str, str]:
    """What one point of page 1's course stands for: (noun, its length in words). The period of
    the trial's motion; under a curve analysis by phase that motion is the perturbation (the
    movement every cycle repeats is taken off), so it is named so, beside the task's cycles."""
    task = task_cycle_s(result)
    if task is None:
        return "motion cycle", f"{course.seconds:.3g} s"
    return "perturbation period", f"{course.seconds:.3g} s; the task's cycles are {task}"


def point_caption(result, course: CycleCourse) -> str:
    """Page 1's caption of a point of the course: ``"a point per motion cycle of 0.912 s"``, or
    ``"a point per perturbation period of 0.684 s (the task's cycles are 1.5 s)"``."""
    noun, length = period_words(result, course)
    seconds, _, task = length.partition("; ")
    return f"a point per {noun} of {seconds}" + (f" ({task})" if task else "")


def range_text(result) -> str:
    """The course's range on page 1: the lowest and highest median over one motion cycle (the
    resolution the data support, :func:`cycle_course`), over the informed cycles."""
    unit = result.trial.units["stiffness"]
    course = cycle_course(result)
    if course.informed.any():
        values = course.stiffness[course.informed]
        noun, length = period_words(result, course)
        plural = "cycles" if noun.endswith("cycle") else "periods"
        return (f"{number(np.min(values))} to {number(np.max(values), unit)}  — lowest and highest median over "
                f"one {noun} ({length}), over the {values.size} informed {plural}")
    _, low, high = result.informed_stiffness()
    where = "informed samples" if result.observable.any() else "all samples: none is informed"
    return f"{number(low)} to {number(high, unit)} over the trial ({where}; no cycle is informed)"


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
    figures = headline_rows(result)
    rows = figures + gloss_rows(result, figures) + [("Warnings", w) for w in result.warnings] + recording_rows(result)
    key = max(len(label) for label, _ in rows) + 2
    for label, text in rows:
        lines.append(textwrap.fill(text, width, initial_indent=f"{label:<{key}}",
                                   subsequent_indent=" " * key))
    return "\n".join(lines)
