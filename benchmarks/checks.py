"""Does the verdict say when the stiffness is wrong? (issue: model checks and a verdict)

    python benchmarks/checks.py [--seeds 5] [--independent-seeds 7300 7400 7500 7600] [--jobs 2] [--duration 20]

Two generators of trials, each analysed with default settings (inertia and damping identified):

* limbstiff's own simulator: every limb scenario, clean and with each of the simulator's effects
  at its default size (the paper's plants clean only), ``--seeds`` seeds each (seeds 1…);
* the independent generator ``tests/support/independent_trials.py`` (written without the
  method's code): its standard suite of 24 trials of 30 s per suite seed (6 clean, 6 with a
  textbook effect, 12 with an effect in another form), suite seeds ``--independent-seeds``.

Seeds: the thresholds of limbstiff/checks/verdict.py were set on seeds 101–102 of the own
simulator and on suite seeds 7100 and 7200 of the independent one (the seeds of
``benchmarks/calibration_independent.py``); the defaults here are other seeds.

For each trial: the verdict and the median relative error of the stiffness over the informed
samples after 2 s. Reported for each generator separately:

* false alarms: the share of clean trials the model fits (median error ≤ FITS = 10 %) whose
  verdict is not ``ok`` (target ≤ 5 %), with a two-sided 95 % Wilson interval;
* detection: the share of trials whose median error exceeds WRONG = 20 % that are flagged
  ``caution`` or ``unreliable`` (target ≥ 90 %), with its interval;
* the verdicts of every scenario × effect (trial × form), and of the real ankle trials.

``--rows FILE`` also writes every trial's verdict, error and check values as JSON.

Writes section ``checks`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]  # benchmarks/, and the repository's root for tests.support
from _results import machine, update_section  # noqa: E402
from tests.support import independent_trials  # noqa: E402

#: Scenarios of the benchmark, with their parameters (durations set by --duration).
LIMBS = ("elbow", "wrist", "ankle", "ankle-coupled", "ankle-platform")
#: The paper's plants run clean only (their effects are not the limbs' effects).
PAPER = ("paper-exp-spring", "paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp")
FITS, WRONG = 0.10, 0.20
REAL = Path(__file__).resolve().parents[1] / "data" / "reklab-ankle"


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Two-sided 95 % Wilson score interval of a proportion k/n."""
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))


def one(job):
    from limbstiff.analysis import analyze
    from limbstiff.simulate import simulate
    scenario, effect, seed, duration = job
    t0 = time.perf_counter()
    try:
        trial = simulate(scenario, seed=seed, params={"duration": duration}, effect=effect)
        result = analyze(trial, seed=seed)
    except Exception as exc:  # noqa: BLE001 - a failed analysis is a result of the benchmark too
        return dict(scenario=scenario, effect=effect, seed=seed, verdict="failed", error=None, checks={},
                    why=" ".join(str(exc).split())[:160], seconds=time.perf_counter() - t0)
    return _row(result, scenario=scenario, effect=effect, seed=seed, t0=t0)


def _row(result, *, t0: float, **row) -> dict:
    err = result.reference_error()
    checks = {c.name: dict(value=c.value, threshold=c.threshold, passed=c.passed, severity=c.severity)
              for c in result.checks.checks}
    return dict(row, verdict=result.verdict, error=err["median"], checks=checks,
                why="; ".join(c.name for c in result.checks.failed), seconds=time.perf_counter() - t0)


def one_independent(job):
    """One trial of the independent generator: (folder, name) of its CSV and truth JSON."""
    from limbstiff.analysis import analyze
    from limbstiff.files import read_trial
    folder, name = job
    truth = json.loads((Path(folder) / f"{name}.json").read_text())
    row = dict(scenario=name, effect=truth["form"], seed=truth["seed"], family=truth["family"])
    t0 = time.perf_counter()
    try:
        result = analyze(read_trial(Path(folder) / f"{name}.csv"), seed=0)
    except Exception as exc:  # noqa: BLE001 - a failed analysis is a result of the benchmark too
        return dict(row, verdict="failed", error=None, checks={}, why=" ".join(str(exc).split())[:160],
                    seconds=time.perf_counter() - t0)
    return _row(result, t0=t0, **row)


def real_rows() -> list[str]:
    import limbstiff
    if not REAL.exists():
        return ["(real data not present)"]
    proto = limbstiff.load_protocol(Path(__file__).resolve().parents[1] / "protocols" / "reklab-ankle.toml")
    rows = ["| trial | median stiffness, N·m/rad | SOURCE.md K | corner | verdict | failed checks |", "|---|---|---|---|---|---|"]
    reference = {"z_df": 90, "z_df2": 54, "z_df3": 139, "z_pf": 69, "z_pf2": 127}
    for name, k in reference.items():
        r = limbstiff.analyze(limbstiff.read_trial(REAL / f"{name}.csv", proto), proto, seed=0)
        s = r.summary()["stiffness"]
        rows.append(f"| {name} | {s['median']:.1f} [{s['lo']:.1f}, {s['hi']:.1f}] | {k} | {r.filtered.cutoff_hz:.0f} Hz | "
                    f"{r.verdict} | {', '.join(c.name for c in r.checks.failed) or '—'} |")
    return rows


def rates(rows, *, gravity: bool = True) -> tuple[list[str], dict]:
    clean_fit = [r for r in rows if r["effect"] is None and r["error"] is not None and r["error"] <= FITS]
    wrong = [r for r in rows if r["error"] is not None and r["error"] > WRONG]
    failed = [r for r in rows if r["verdict"] == "failed"]
    fa = sum(r["verdict"] != "ok" for r in clean_fit)
    det = sum(r["verdict"] in ("caution", "unreliable") for r in wrong)
    no_gravity = [r for r in wrong if r["effect"] != "gravity"]
    det_ng = sum(r["verdict"] in ("caution", "unreliable") for r in no_gravity)
    accurate = [r for r in rows if r["error"] is not None and r["error"] <= FITS]
    flagged_accurate = sum(r["verdict"] != "ok" for r in accurate)
    lo, hi = wilson(fa, len(clean_fit))
    dlo, dhi = wilson(det, len(wrong))
    text = [f"- False alarms on clean trials the model fits (median error ≤ {FITS:.0%}): **{fa}/{len(clean_fit)} = "
            f"{100 * fa / max(len(clean_fit), 1):.1f} %** [95 % interval {100 * lo:.1f}, {100 * hi:.1f}] (target ≤ 5 %).",
            f"- Detection of trials with median error > {WRONG:.0%}: **{det}/{len(wrong)} = {100 * det / max(len(wrong), 1):.1f} %** "
            f"[{100 * dlo:.1f}, {100 * dhi:.1f}] (target ≥ 90 %)" + (
                f"; without gravity (a torque −mgl·sin y that is a stiffness change by construction): "
                f"{det_ng}/{len(no_gravity)}." if gravity else "."),
            f"- Trials with effects whose stiffness is still right (error ≤ {FITS:.0%}) flagged anyway: "
            f"{flagged_accurate}/{len(accurate)} (not a false alarm: the model misses part of the torque, "
            "and the verdict says so).",
            f"- Analyses that failed outright (a clear error instead of a number): {len(failed)}.",
            "- Missed (error > 20 %, verdict ok): " + (", ".join(
                f"{r['scenario']}/{r['effect'] or 'clean'}#{r['seed']} ({100 * r['error']:.0f} %)"
                for r in wrong if r["verdict"] == "ok") or "none") + "; false alarms: " + (", ".join(
                f"{r['scenario']}#{r['seed']} ({100 * r['error']:.1f} %, {r['why']})"
                for r in clean_fit if r["verdict"] != "ok") or "none") + "."]
    alone = Counter(r["why"] for r in clean_fit if r["verdict"] != "ok" and "; " not in r["why"])
    if alone:
        text.append("- False alarms from one check alone: " + ", ".join(f"{k} {v}" for k, v in alone.most_common())
                    + f"; without them {fa - sum(alone.values())}/{len(clean_fit)}.")
    return text, {"false_alarm": (fa, len(clean_fit)), "detection": (det, len(wrong))}


def table(rows) -> list[str]:
    by = defaultdict(list)
    for r in rows:
        by[(r["scenario"], r["effect"] or "clean")].append(r)
    out = ["| scenario | effect | verdicts (ok/caution/unreliable/failed) | median error (range) | checks failed (most often) |",
           "|---|---|---|---|---|"]
    for (sc, eff), rs in by.items():
        c = Counter(r["verdict"] for r in rs)
        errs = [r["error"] for r in rs if r["error"] is not None]
        err = (f"{100 * np.median(errs):.1f} % ({100 * min(errs):.1f}–{100 * max(errs):.1f})" if errs else "—")
        why = Counter(w for r in rs for w in r["why"].split("; ") if w and r["verdict"] != "failed")
        fails = [r["why"] for r in rs if r["verdict"] == "failed"]
        reasons = ", ".join(f"{k} {v}" for k, v in why.most_common(2)) or ("; ".join(fails[:1]) if fails else "—")
        out.append(f"| {sc} | {eff} | {c['ok']}/{c['caution']}/{c['unreliable']}/{c['failed']} | {err} | {reasons} |")
    return out


def run_independent(seeds, jobs: int) -> list[dict]:
    """Rows of the independent generator's suites (one per suite seed)."""
    if not seeds:
        return []
    with tempfile.TemporaryDirectory() as tmp:
        names = independent_trials.write_suites(seeds, Path(tmp))
        with ProcessPoolExecutor(jobs) as pool:
            return list(pool.map(one_independent, names))


def main(seeds: int, jobs: int, duration: float, independent_seeds=(), first: int = 1,
         rows_path: Path | None = None) -> str:
    from limbstiff.simulate import EFFECTS, SCENARIOS as KNOWN
    scenarios = [s for s in LIMBS + PAPER if s in KNOWN]
    own_seeds = range(first, first + seeds)
    work = [(sc, eff, seed, duration) for sc in scenarios for eff in ((None, *EFFECTS) if sc in LIMBS else (None,))
            for seed in own_seeds]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, work, chunksize=2))
    wall = time.perf_counter() - t0
    t0 = time.perf_counter()
    independent = run_independent(list(independent_seeds), jobs)
    wall_independent = time.perf_counter() - t0
    if rows_path is not None:
        rows_path.write_text(json.dumps({"own": rows, "independent": independent, "wall": wall, "jobs": jobs,
                                         "wall_independent": wall_independent, "first": first, "seeds": seeds,
                                         "independent_seeds": list(independent_seeds), "duration": duration},
                                        indent=0, default=float))
    return report(rows, independent, wall=wall, wall_independent=wall_independent, jobs=jobs, first=first,
                  seeds=seeds, independent_seeds=independent_seeds, duration=duration)


def from_rows(paths) -> str:
    """The report of rows written by earlier runs (``--rows``): the own simulator's from the first file
    that has them, the independent generator's likewise."""
    runs = [json.loads(Path(p).read_text()) for p in paths]
    own = next(r for r in runs if r["own"])
    ind = next(r for r in runs if r["independent"])
    return report(own["own"], ind["independent"], wall=own["wall"], wall_independent=ind["wall_independent"],
                  jobs=own["jobs"], first=own["first"], seeds=own["seeds"],
                  independent_seeds=ind["independent_seeds"], duration=own["duration"])


def report(rows, independent, *, wall, wall_independent, jobs, first, seeds, independent_seeds, duration) -> str:
    from limbstiff.simulate import EFFECTS, SCENARIOS as KNOWN
    scenarios = [s for s in LIMBS + PAPER if s in KNOWN]
    own_seeds = range(first, first + seeds)
    lines = ["## Model checks and the verdict (`benchmarks/checks.py`)", "",
             f"Definitions: a trial the model fits has a median stiffness error ≤ {FITS:.0%} (over the informed "
             f"samples after 2 s); a wrong stiffness, > {WRONG:.0%}. False alarms: clean trials the model fits "
             "whose verdict is not ok (target ≤ 5 %); detection: wrong trials whose verdict is caution or "
             "unreliable (target ≥ 90 %). Intervals: two-sided 95 % Wilson. Default settings, m and b identified. "
             f"Machine: {machine()}.", ""]
    if rows:
        lines += ["### limbstiff's own simulator", "",
                  f"{len(rows)} simulated trials of {duration:.0f} s ({', '.join(scenarios)}; clean and with each of "
                  f"the {len(EFFECTS)} effects at its default size; seeds {own_seeds[0]}–{own_seeds[-1]}); "
                  f"{wall / 60:.1f} min on {jobs} processes.", "", *rates(rows)[0], "", *table(rows)]
    if independent:
        summary_i, _ = rates(independent, gravity=False)
        lines += ["", "### The independent generator (`tests/support/independent_trials.py`)", "",
                  f"{len(independent)} trials of 30 s (suite seeds {', '.join(map(str, independent_seeds))}: per seed "
                  "6 clean — constant, co-contraction with a cubic spring, ramp, gait, pause, antagonistic-spring "
                  "actuator —, 6 with a textbook effect, 12 with an effect in another form); "
                  f"{wall_independent / 60:.1f} min on {jobs} processes.", "", *summary_i, "",
                  *table(independent)]
    lines += ["", "### Real ankle trials (`protocols/reklab-ankle.toml`)", "", *real_rows()]
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=1, help="first seed of the own simulator")
    parser.add_argument("--independent-seeds", type=int, nargs="*", default=[7300, 7400, 7500, 7600])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--rows", type=Path, help="write every trial's row (verdict, error, checks) here as JSON")
    parser.add_argument("--no-update", action="store_true", help="do not write RESULTS.md")
    parser.add_argument("--from-rows", type=Path, nargs="+",
                        help="report the rows of earlier runs (--rows) instead of running")
    args = parser.parse_args()
    text = (from_rows(args.from_rows) if args.from_rows else
            main(args.seeds, args.jobs, args.duration, args.independent_seeds, args.first_seed, args.rows))
    if not args.no_update:
        update_section("checks", text)
    print(text)
