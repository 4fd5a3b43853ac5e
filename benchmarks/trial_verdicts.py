"""Issue 46's figures of a trial's verdict: does ``ok`` mean the band holds the truth?

Shared by ``reflex_study.py`` (the gated reflex, an independent generator) and
``own_verdicts.py`` (limbstiff's own simulator, clean trials: the false alarms and the bands'
width). One row per analysis (:func:`verdict_fields`); a summary per group of rows
(:func:`summarise`): the share said ``ok``; among those, the course band's coverage of the truth
(pooled informed samples after 2 s) and the ``median_stiffness`` interval's (trials: the true
course's median over the figure's own samples, the informed ones from the start), each with a
95 % Wilson interval; the median error; and how often the stiffness was said to depend on the angle.

The course's samples are strongly correlated in time: a Wilson interval over pooled samples is
far narrower than the coverage's real uncertainty; the per-trial interval of the median is the
honest one. Both are given because issue 46 asks for both.
"""

from __future__ import annotations

import numpy as np

from checks import wilson

#: The first words of the angle-dependence reason that reads the change as the joint's property.
ANGLE_PROPERTY = "the joint's stiffness depends on its angle"


def verdict_fields(result, truth: float | None = None) -> dict:
    """A result's verdict and how its bands hold the truth (the trial's reference stiffness).

    Returns
    -------
    dict
        ``coverage`` and ``samples`` (course band over the reference samples), ``median_interval``
        (lo, hi) and ``median_holds`` (whether it holds the true course's median, or ``truth``),
        ``band_width`` (median band width over |median stiffness|, informed samples), ``reasons``
        (the failed checks' messages), ``angle_property`` (the angle-dependence reason as the
        joint's property given), ``angle_failed`` (the angle check failed at all).
    """
    err = result.reference_error() or {}
    median, _, _ = result.informed_stiffness()
    if truth is None:
        truth = _true_median(result)
    obs = result.observable
    centre = float(np.median(result.stiffness[obs])) if np.any(obs) else float("nan")
    width = float(np.median((result.stiffness_hi - result.stiffness_lo)[obs])) / abs(centre) if np.any(obs) else None
    failed = result.checks.failed
    angle = [c for c in failed if c.name == "angle_dependence"]
    return dict(coverage=err.get("coverage"), samples=int(err.get("n") or 0),
                median_interval=[float(median.lo), float(median.hi)],
                median_holds=bool(median.lo <= truth <= median.hi) if np.isfinite(median.lo) else None,
                band_width=width, reasons=[c.message for c in failed],
                angle_property=any(c.message.startswith(ANGLE_PROPERTY) for c in angle),
                angle_failed=bool(angle))


def _true_median(result) -> float:
    """The true course's median over the samples the ``median_stiffness`` figure is taken over
    (what its interval claims to hold: :func:`accuracy.trial_level_truth`, as
    ``calibration_independent.py`` and ``identify.py`` compare it); without trial-level figures,
    over the reference samples."""
    from accuracy import trial_level_truth
    if result.reference is None:
        return float("nan")
    pairs = trial_level_truth(result)
    if pairs is not None:
        return pairs[0][1]
    use = result.reference_samples()
    return float(np.median(result.reference[use])) if np.any(use) else float("nan")


def _share(k: int, n: int) -> dict:
    lo, hi = wilson(k, n)
    return dict(k=int(k), n=int(n), share=None if n == 0 else k / n, lo=lo, hi=hi)


def summarise(rows) -> dict:
    """The issue's figures over ``rows`` (analyses that ran; failed ones count as not ``ok``)."""
    rows = [r for r in rows if r.get("verdict") not in (None, "not available")]
    ok = [r for r in rows if r["verdict"] == "ok"]
    pooled = [(r["coverage"] * r["samples"], r["samples"]) for r in ok if r.get("coverage") is not None]
    inside = int(round(sum(k for k, _ in pooled)))
    medians = [r for r in ok if r.get("median_holds") is not None]
    errors = [r["error"] for r in ok if r.get("error") is not None]
    return dict(runs=len(rows), ok=_share(len(ok), len(rows)),
                course=_share(inside, sum(n for _, n in pooled)),
                course_trials=[r["coverage"] for r in ok if r.get("coverage") is not None],
                median=_share(sum(r["median_holds"] for r in medians), len(medians)),
                error=float(np.median(errors)) if errors else None,
                angle_property=sum(bool(r.get("angle_property")) for r in rows),
                angle_failed=sum(bool(r.get("angle_failed")) for r in rows),
                verdicts={v: sum(r["verdict"] == v for r in rows) for v in ("ok", "caution", "unreliable", "failed")})


def _pct(x) -> str:
    return "—" if x is None or not np.isfinite(x) else f"{100 * x:.0f} %"


def _with_interval(s: dict) -> str:
    if not s["n"]:
        return "— (0)"
    return f"{_pct(s['share'])} [{_pct(s['lo'])}, {_pct(s['hi'])}] ({s['k']}/{s['n']})"


def summary_table(summaries: dict, *, truth: str = "30") -> list[str]:
    """One line per (label, group): ``summaries`` maps a label ("before", "after"…) to
    {group name: :func:`summarise`'s dict}; ``truth`` names what the median's interval is held
    against in the header."""
    out = ["| code | runs | verdicts ok/caution/unreliable/failed | said ok [95 % Wilson] | course coverage among ok, "
           "pooled samples [95 % Wilson] | median trials' coverage among ok, per trial (min) | median interval holds "
           f"{truth} among ok [95 % Wilson] | median error among ok | angle as the joint's property / angle check failed |",
           "|---|---|---|---|---|---|---|---|---|"]
    for label, groups in summaries.items():
        for name, s in groups.items():
            v = s["verdicts"]
            trials = s["course_trials"]
            per = "—" if not trials else f"{_pct(float(np.median(trials)))} ({_pct(min(trials))})"
            error = "—" if s["error"] is None else f"{100 * s['error']:.1f} %"
            out.append(f"| {label} | {name} ({s['runs']}) | {v['ok']}/{v['caution']}/{v['unreliable']}/{v['failed']} | "
                       f"{_with_interval(s['ok'])} | {_with_interval(s['course'])} | {per} | "
                       f"{_with_interval(s['median'])} | "
                       f"{error} | "
                       f"{s['angle_property']} / {s['angle_failed']} |")
    return out
