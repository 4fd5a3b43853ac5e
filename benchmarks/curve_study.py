"""Stiffness by phase and by schedule on an independent generator (issue 36).

    python benchmarks/curve_study.py [--quick] [--jobs 2] [--before]

The trials come from ``benchmarks/ensemble_sim.py``, written by a helper who never read limbstiff's
method: repeated-cycle ensembles (sinusoidal, gait-like and stepped stiffness over the phase;
pseudo-random, continuous and torque perturbations; reflexes modulated by phase, drifting
operating points, unequal cycles; 20–200 cycles) and parameter-varying trials (stiffness a
function of a slowly swept, recorded position). Each is written as CSV (``time_s, angle_rad,
torque_Nm, marker, schedule_rad``) and analysed as a lab would: ensembles with ``[cycles] marker =
"marker"``, parameter-varying trials with the ``schedule_rad`` column.

Per trial, over the curve's informed bins: |error| of the bin's stiffness against the true
stiffness averaged over the bin, relative to it; whether the band holds the truth; the band's
relative width. When the first analysis's ``reflex`` check fails, the trial is analysed again with
``effects=("reflex",)``, the command the check names, and that second analysis is scored (both
verdicts recorded). Pooled over the trials with at least 40 cycles (and the schedule trials): the
median and 90th percentile of the errors, the coverage, the width. One timing: a 100-cycle ensemble
of 1.5 s cycles analysed as an ensemble and as one 150 s trial, CPU time of each (medians of
alternating runs are not taken: one run each; the ratio is stated with that caveat).

Issue 46: each curve's own verdict (before it had one, the trial's, which its page said applies to
the curve), the least-squares cross-check and the least-squares curve's own error; pooled, the
share of curves said ``ok``, the coverage among them (bins whose band holds the truth, with a 95 %
Wilson interval), their median error, and every ``ok`` curve whose band holds the truth on fewer
than :data:`OK_COVERAGE` of its bins. Four trials of ``benchmarks/generators/ensembles.py`` (a
sharp stiffness trough, 25–45 ms reflexes, small perturbations on large imposed cycles) join
the study. ``--before`` stores the run's figures as the ``before`` block of the JSON (run on the
library before issue 46); later runs keep that block and print both. ``--previous LABEL`` keeps
the JSON's last figures as a ``previous`` row named LABEL (the figures before one change).

Writes section ``curve-study`` of ``benchmarks/RESULTS.md`` and ``benchmarks/curve_study.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from _results import machine, update_section  # noqa: E402
import ensemble_sim  # noqa: E402

#: Cycles at least for the issue's targets.
TARGET_CYCLES = 40
#: Issue 46: an ``ok`` curve's band holds the truth on at least this share of its bins.
OK_COVERAGE = 0.85
#: Trials of ``benchmarks/generators/ensembles.py`` added to the study (scenario, seed).
GENERATED = (("trough", 0), ("reflex", 0), ("trough_reflex", 0), ("trough_reflex", 1))


def _cases(quick: bool) -> list[tuple[str, dict]]:
    """``ensemble_sim.cases`` and the :data:`GENERATED` trials (the first two with ``quick``)."""
    extra = [(f"gen_{sc}_s{seed}", {"generator": "ensembles", "scenario": sc, "seed": seed})
             for sc, seed in (GENERATED[:2] if quick else GENERATED)]
    return ensemble_sim.cases(quick=quick) + extra


class _Generated:
    """A ``benchmarks/generators/ensembles.py`` trial with the fields the study reads."""

    def __init__(self, kwargs: dict):
        from generators.ensembles import scenario_trial
        self.trial = scenario_trial(kwargs["scenario"], kwargs["seed"])
        settings = self.trial.params["settings"]
        self.truth_grid, self.truth_curve = self.trial.truth_grid, self.trial.truth_curve
        self.inertia, self.damping = settings["inertia"], settings["damping"]
        self.n_cycles = settings["n_cycles"]

    def write(self, folder: Path) -> Path:
        from generators._common import write_trial_csv
        return write_trial_csv(self.trial, folder)


def _protocol(kind: str):
    from limbstiff.protocol import Cycles, Protocol
    if kind == "phase":
        return Protocol(variant="external", cycles=Cycles(marker="marker"))
    return Protocol(variant="external")


def _truth_in_bins(trial, curve) -> np.ndarray:
    """The true stiffness averaged over each bin (fine grid of 20 points per bin)."""
    out = []
    for a, b in zip(curve.edges[:-1], curve.edges[1:]):
        x = np.linspace(a, b, 21)
        if curve.against == "phase":
            out.append(np.mean(np.interp(x % 1.0, trial.truth_grid, trial.truth_curve, period=1.0)))
        else:
            out.append(np.mean(np.interp(x, trial.truth_grid, trial.truth_curve)))
    return np.array(out)


def run_case(name: str, kwargs: dict) -> dict:
    import limbstiff
    generated = kwargs.get("generator") == "ensembles"
    trial = _Generated(kwargs) if generated else ensemble_sim.make(kwargs)
    kind = "phase" if "shape" in kwargs or generated else "schedule"
    with tempfile.TemporaryDirectory() as tmp:
        if generated:
            path = trial.write(Path(tmp))
        else:
            path = Path(tmp) / f"{name}.csv"
            ensemble_sim.write_csv(trial, path)
        t0 = time.process_time()
        try:
            result = limbstiff.analyze(path, _protocol(kind))
            first = result.verdict
            # as a lab would: the reflex check names the command to run, and it is run
            named = any(c.name == "reflex" for c in result.checks.failed)
            if named:
                result = limbstiff.analyze(path, _protocol(kind).override(effects=("reflex",)))
        except limbstiff.errors.LimbstiffError as exc:
            return {"name": name, "kind": kind, "error": str(exc), **_meta(kwargs, trial)}
        cpu = time.process_time() - t0
    curve = result.by_phase if kind == "phase" else result.by_schedule
    truth = _truth_in_bins(trial, curve)
    ok = curve.informed
    err = np.abs(curve.stiffness[ok] - truth[ok]) / truth[ok]
    inside = (truth[ok] >= curve.lo[ok]) & (truth[ok] <= curve.hi[ok])
    return {"name": name, "kind": kind, **_meta(kwargs, trial), "cpu_s": cpu, "verdict": result.verdict,
            **_curve_verdict(result, truth),
            "first_verdict": first, "rerun_with_reflex": named,
            "reasons": list(result.checks.reasons), "knots": int(result.curve.resolution.chosen),
            "bins": int(ok.sum()), "median_error": float(np.median(err)), "p90_error": float(np.percentile(err, 90)),
            "errors": err.tolist(), "inside": inside.astype(int).tolist(),
            "coverage": float(inside.mean()), "relative_width": float(np.median((curve.hi - curve.lo)[ok] / truth[ok])),
            "inertia": [result.inertia.median, trial.inertia], "damping": [result.damping.median, trial.damping]}


def _meta(kwargs: dict, trial=None) -> dict:
    if kwargs.get("generator") == "ensembles":
        return {"n_cycles": trial.n_cycles, "shape": kwargs["scenario"], "reflex": "reflex" in kwargs["scenario"],
                "perturbation": "prbs (small, on imposed cycles)", "sweep": None}
    return {"n_cycles": kwargs.get("n_cycles"), "shape": kwargs.get("shape"), "reflex": kwargs.get("reflex"),
            "perturbation": kwargs.get("perturbation"), "sweep": kwargs.get("sweep")}


def _curve_verdict(result, truth: np.ndarray) -> dict:
    """The curve's own verdict and reasons (before issue 46 there were none: the trial's, which
    the curve's page said applies to the curve), the least-squares cross-check and the
    least-squares curve's own error against the truth (None before)."""
    analysis = result.curve
    own = getattr(analysis, "verdict", None)
    out = {"curve_verdict": str(own if own is not None else result.verdict),
           "curve_verdict_from": "curve" if own is not None else "trial",
           "curve_reasons": list(analysis.reasons if own is not None else result.checks.reasons),
           "cross_check": None, "ls_median_error": None, "ls_bins": 0,
           "width_ratio": getattr(analysis.curve, "width_ratio", None)}
    ls = getattr(analysis, "least_squares", None)
    if ls is not None:
        check = next(c for c in analysis.band_checks if c.name == "curve_least_squares")
        out["cross_check"] = {"passed": check.passed, "value": check.value, "threshold": check.threshold,
                              "message": check.message}
        use = np.isfinite(ls.stiffness)
        if use.any():
            out["ls_median_error"] = float(np.median(np.abs(ls.stiffness[use] - truth[use]) / truth[use]))
            out["ls_bins"] = int(use.sum())
    return out


def timing() -> dict:
    """CPU of a 100-cycle, 1.5 s ensemble analysed as an ensemble and as one 150 s trial."""
    import limbstiff
    trial = ensemble_sim.ensemble("gait", n_cycles=100, period_s=1.5, seed=4242)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "timing.csv"
        ensemble_sim.write_csv(trial, path)
        whole = limbstiff.read_trial(path, _protocol("whole"))
        whole = dataclasses.replace(whole, schedule=None, schedule_unit=None)   # one plain 150 s trial
        limbstiff.analyze(whole, _protocol("whole"))           # compile and warm up
        out = {}
        for label, kind in (("whole_trial_cpu_s", "whole"), ("ensemble_cpu_s", "phase")):
            t0 = time.process_time()
            limbstiff.analyze(whole if kind == "whole" else path, _protocol(kind))
            out[label] = time.process_time() - t0
    out["ratio"] = out["ensemble_cpu_s"] / out["whole_trial_cpu_s"]
    return out


#: The real ankle trials' own cycles: fixed-length cycles of the real ensemble's period (issue 36).
REAL_PERIOD_S = 1.5


def real_ankle() -> list[dict]:
    """The shared real ankle trials (steady tasks) analysed whole and as ensembles of their own
    1.5 s cycles: the curve's median against the whole trial's (and its interval), and how flat the
    curve is — the share of its informed bins whose band holds the curve's own median."""
    import limbstiff
    from limbstiff.protocol import Cycles, load_protocol
    protocol = load_protocol(HERE.parent / "protocols" / "reklab-ankle.toml")
    out = []
    for path in sorted((HERE.parent / "data" / "reklab-ankle").glob("z_*.csv")):
        whole = limbstiff.analyze(path, protocol)
        t0 = time.process_time()
        ens = limbstiff.analyze(path, protocol.override(cycles=Cycles(period_s=REAL_PERIOD_S)))
        cpu = time.process_time() - t0
        curve = ens.by_phase
        ok = curve.informed
        med = float(np.median(curve.stiffness[ok]))
        iv, _, _ = whole.informed_stiffness()
        out.append({"trial": path.stem, "whole_median": iv.median, "whole_lo": iv.lo, "whole_hi": iv.hi,
                    "whole_verdict": whole.verdict, "curve_median": med, "curve_min": float(curve.stiffness[ok].min()),
                    "curve_max": float(curve.stiffness[ok].max()), "n_cycles": ens.curve.prepared["n_cycles"],
                    "knots": int(ens.curve.resolution.chosen),
                    "flat_share": float(np.mean((curve.lo[ok] <= med) & (med <= curve.hi[ok]))),
                    "trial_verdict": ens.verdict, "curve_verdict": str(getattr(ens.curve, "verdict", None) or ens.verdict),
                    "curve_reasons": list(getattr(ens.curve, "reasons", None) or ens.checks.reasons), "cpu_s": cpu})
    return out


def pooled(rows: list[dict], kind: str) -> dict:
    use = [r for r in rows if r["kind"] == kind and "error" not in r and not r["name"].startswith("gen_")
           and (kind != "phase" or r["n_cycles"] >= TARGET_CYCLES)]
    if not use:
        return {}
    err = np.concatenate([r["errors"] for r in use])
    inside = np.concatenate([r["inside"] for r in use])
    return {"trials": len(use), "bins": int(err.size), "median_error": float(np.median(err)),
            "p90_error": float(np.percentile(err, 90)), "coverage": float(inside.mean()),
            "relative_width": float(np.median([r["relative_width"] for r in use])),
            "verdicts": {v: sum(r["verdict"] == v for r in use) for v in ("ok", "caution", "unreliable")}}


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Two-sided 95 % Wilson score interval of a proportion k/n."""
    if n == 0:
        return (float("nan"), float("nan"))
    p, d = k / n, 1 + z * z / n
    c, h = (p + z * z / (2 * n)) / d, z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))


def ok_figures(rows: list[dict]) -> dict:
    """Issue 46's figures over ``rows``: the share of curves said ``ok``, the coverage among them
    (bins pooled, 95 % Wilson interval), their median error (bins pooled), the band's median relative
    width, and every ``ok`` curve whose band holds the truth on fewer than :data:`OK_COVERAGE` of its bins."""
    done = [r for r in rows if "error" not in r]
    ok = [r for r in done if r["curve_verdict"] == "ok"]
    inside = np.concatenate([r["inside"] for r in ok]) if ok else np.zeros(0)
    k, n = int(inside.sum()), int(inside.size)
    ls = [r["ls_median_error"] for r in done if r.get("ls_median_error") is not None]
    ratios = [r["width_ratio"] for r in done if r.get("width_ratio") is not None]
    return {"curves": len(done), "ok": len(ok), "ok_share": len(ok) / len(done) if done else None,
            "ls_median_error": float(np.median(ls)) if ls else None,
            "width_ratio": float(np.median(ratios)) if ratios else None,
            "cross_check_failed": sum(1 for r in done if r.get("cross_check") and not r["cross_check"]["passed"]),
            "ok_bins": n, "ok_coverage": k / n if n else None, "ok_coverage_wilson": list(wilson(k, n)),
            "ok_median_error": float(np.median(np.concatenate([r["errors"] for r in ok]))) if ok else None,
            "relative_width": float(np.median([r["relative_width"] for r in done])) if done else None,
            "exceptions": [{"name": r["name"], "coverage": r["coverage"]} for r in ok if r["coverage"] < OK_COVERAGE],
            "rows": [{k: r[k] for k in ("name", "curve_verdict", "coverage", "median_error", "relative_width")}
                     for r in done]}


def _ok_lines(out: dict) -> list[str]:
    """Issue 46's table: the figures before (the ``before`` block) and now."""
    lines = ["\nIssue 46 — curves said `ok` (the curve's own verdict; before issue 46 the trial's), all curves:\n",
             "| run | curves | said ok | coverage among ok [95 % Wilson] | median error among ok | band width | "
             "ok curves holding the truth on < 85 % of bins |", "|---|---|---|---|---|---|---|"]
    previous = out.get("previous") or {}
    for label, fig in (("before", out.get("before", {}).get("ok")), (previous.get("label"), previous.get("ok")),
                       ("now", out.get("ok"))):
        if not fig or not label:
            continue
        cov = "–" if fig["ok_coverage"] is None else (
            f"{100 * fig['ok_coverage']:.0f} % [{100 * fig['ok_coverage_wilson'][0]:.0f}, "
            f"{100 * fig['ok_coverage_wilson'][1]:.0f}] of {fig['ok_bins']} bins")
        err = "–" if fig["ok_median_error"] is None else f"{100 * fig['ok_median_error']:.1f} %"
        exc = ", ".join(f"{e['name']} ({100 * e['coverage']:.0f} %)" for e in fig["exceptions"]) or "none"
        lines.append(f"| {label} | {fig['curves']} | {fig['ok']} ({100 * fig['ok_share']:.0f} %) | {cov} | {err} | "
                     f"{100 * fig['relative_width']:.1f} % | {exc} |")
    now = out.get("ok") or {}
    if now.get("ls_median_error") is not None:
        lines.append(f"\nNow: the least-squares cross-check failed on {now['cross_check_failed']} of {now['curves']} curves; "
                     f"the least-squares curve's own median error (median over the curves) "
                     f"{100 * now['ls_median_error']:.1f} %; the band's width over the posterior's alone "
                     f"(median over the curves of each curve's median over its bins) {now['width_ratio']:.2f}.")
    return lines


def _verdict_cell(r: dict) -> str:
    return r.get("curve_verdict", "–") + (" (the trial's)" if r.get("curve_verdict_from") == "trial" else "")


def _cross_cell(r: dict) -> str:
    c = r.get("cross_check")
    return "–" if c is None else ("agrees" if c["passed"] else f"disagrees ({c['value']:.0f} bins)")


def _ls_cell(r: dict) -> str:
    e = r.get("ls_median_error")
    return "–" if e is None else f"{100 * e:.1f} % ({r['ls_bins']} bins)"


def section(out: dict) -> str:
    """The ``curve-study`` section of RESULTS.md from a run's results (``curve_study.json``)."""
    rows = out["rows"]
    lines = ["| trial | cycles | knots | median error | p90 | coverage | width | verdict (first, if rerun with --effect reflex) "
             "| curve verdict | cross-check | least squares: median error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['name']} | {r['n_cycles']} | – | error: {r['error']} | | | | | | | |")
            continue
        lines.append(f"| {r['name']} | {r['n_cycles'] or '–'} | {r['knots']} | {100 * r['median_error']:.1f} % | "
                     f"{100 * r['p90_error']:.1f} % | {100 * r['coverage']:.0f} % | {100 * r['relative_width']:.1f} % | "
                     f"{r['verdict']}{' (' + r['first_verdict'] + ')' if r['rerun_with_reflex'] else ''} | "
                     f"{_verdict_cell(r)} | {_cross_cell(r)} | "
                     f"{_ls_cell(r)} |")
    for kind in ("phase", "schedule"):
        p = out[f"by_{kind}"]
        if p:
            lines.append(f"\nPooled by {kind} ({p['trials']} trials, {p['bins']} bins): median error "
                         f"{100 * p['median_error']:.1f} %, 90th percentile {100 * p['p90_error']:.1f} %, coverage "
                         f"{100 * p['coverage']:.0f} %, band width {100 * p['relative_width']:.1f} % of the stiffness; "
                         f"verdicts {p['verdicts']}.")
    lines += _ok_lines(out)
    # issue 36's figures: ensemble_sim's trials (the generated ones are issue 46's, above)
    done = [r for r in rows if "error" not in r and not r["name"].startswith("gen_")]
    wrong = [r for r in done if r["median_error"] > 0.05]
    ok = [r for r in done if r["verdict"] == "ok"]
    lines.append(f"\nTrials whose curve is more than 5 % off (median over its bins): {len(wrong)} of {len(done)}, "
                 f"verdicts {dict(Counter(str(r['verdict']) for r in wrong))}. The {len(ok)} trials said `ok`: median error "
                 f"{100 * np.median([r['median_error'] for r in ok]):.1f} % (at most "
                 f"{100 * max(r['median_error'] for r in ok):.1f} %), coverage "
                 f"{100 * np.mean(np.concatenate([r['inside'] for r in ok])):.0f} %. Band half-width ÷ median error, "
                 f"median over the trials: {np.median([r['relative_width'] / 2 / max(r['median_error'], 1e-9) for r in done]):.2f}.")
    with_reflex = [r for r in done if r.get("reflex")]
    without = [r for r in done if not r.get("reflex")]
    lines.append(f"\nThe `reflex` check fired (and the trial was analysed again with the reflex in the model) on "
                 f"{sum(r['rerun_with_reflex'] for r in with_reflex)} of the {len(with_reflex)} trials whose generator "
                 f"has a reflex, and on {sum(r['rerun_with_reflex'] for r in without)} of the {len(without)} without.")
    if out.get("timing"):
        t = out["timing"]
        lines.append(f"\nTiming (CPU, one run each): 100 cycles of 1.5 s as an ensemble {t['ensemble_cpu_s']:.1f} s, "
                     f"as one 150 s trial {t['whole_trial_cpu_s']:.1f} s: ratio {t['ratio']:.2f}.")
    if out.get("real_ankle"):
        lines += ["\nReal ankle trials (steady tasks) as ensembles of their own 1.5 s cycles:\n",
                  "| trial | whole trial: median [90 %] | verdict | cycles | knots | curve: median, range | bins whose band "
                  "holds the curve's median | verdict |", "|---|---|---|---|---|---|---|---|"]
        for r in out["real_ankle"]:
            lines.append(f"| {r['trial']} | {r['whole_median']:.1f} [{r['whole_lo']:.1f}, {r['whole_hi']:.1f}] | "
                         f"{r['whole_verdict']} | {r['n_cycles']} | {r['knots']} | {r['curve_median']:.1f}, "
                         f"{r['curve_min']:.1f}–{r['curve_max']:.1f} | {100 * r['flat_share']:.0f} % | {r['curve_verdict']} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-timing", action="store_true")
    ap.add_argument("--from-json", action="store_true", help="rewrite the section from curve_study.json only")
    ap.add_argument("--before", action="store_true", help="store this run's figures as the JSON's `before` block")
    ap.add_argument("--previous", metavar="LABEL",
                    help="keep the JSON's last figures as a `previous` row named LABEL (a change's own before)")
    args = ap.parse_args()
    if args.from_json:
        text = section(json.loads((HERE / "curve_study.json").read_text()))
        update_section("curve-study", text)
        print(text)
        return
    cases = _cases(args.quick)
    previous = json.loads((HERE / "curve_study.json").read_text()) if (HERE / "curve_study.json").exists() else {}
    t0 = time.time()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(run_case, *zip(*cases)))
    out = {"machine": machine(), "quick": args.quick, "wall_s": time.time() - t0, "rows": rows,
           "by_phase": pooled(rows, "phase"), "by_schedule": pooled(rows, "schedule"), "timing": None,
           "ok": ok_figures(rows)}
    out["before"] = ({"ok": out["ok"], "by_phase": out["by_phase"], "by_schedule": out["by_schedule"],
                      "wall_s": out["wall_s"]} if args.before else previous.get("before", {}))
    out["previous"] = ({"label": args.previous, "ok": previous.get("ok")} if args.previous
                       else previous.get("previous"))
    (HERE / "curve_study.json").write_text(json.dumps(out, indent=1))
    if args.no_timing:                  # the last measured timing is kept, said as such by its commit
        out["timing"] = previous.get("timing")
    else:
        out["timing"] = timing()
        (HERE / "curve_study.json").write_text(json.dumps(out, indent=1))
    out["real_ankle"] = real_ankle()
    (HERE / "curve_study.json").write_text(json.dumps(out, indent=1))
    text = section(out)
    update_section("curve-study", text)
    print(text)


if __name__ == "__main__":
    main()
