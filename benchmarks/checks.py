"""Does the verdict say when the stiffness is wrong? (issue: model checks and a verdict)

    python benchmarks/checks.py [--seeds 5] [--jobs 2] [--duration 20]

Simulated trials of every limb scenario, clean and with each of the simulator's effects at its
default size (the paper's plants clean only), ``--seeds`` seeds each (seeds 1…; the thresholds of limbstiff/checks/verdict.py
were set on seeds 101–102), analysed with default settings (inertia and damping identified).
For each trial: the verdict and the median relative error of the stiffness over the informed
samples after 2 s. Reported:

* false alarms: the share of clean trials the model fits (median error ≤ 10 %) whose verdict
  is not ``ok`` (target ≤ 5 %), with a 95 % Wilson interval;
* detection: the share of trials whose median error exceeds 20 % that are flagged
  ``caution`` or ``unreliable`` (target ≥ 90 %), with its interval;
* the verdicts of every scenario × effect, and of the real ankle trials.

Writes section ``checks`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine, update_section  # noqa: E402

#: Scenarios of the benchmark, with their parameters (durations set by --duration).
LIMBS = ("elbow", "wrist", "ankle", "ankle-coupled", "ankle-platform")
#: The paper's plants run clean only (their effects are not the limbs' effects).
PAPER = ("paper-exp-spring", "paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp")
FITS, WRONG = 0.10, 0.20
REAL = Path(__file__).resolve().parents[1] / "data" / "reklab-ankle"


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a proportion k/n."""
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
        return dict(scenario=scenario, effect=effect, seed=seed, verdict="failed", error=None,
                    why=" ".join(str(exc).split())[:160], seconds=time.perf_counter() - t0)
    err = result.reference_error()
    return dict(scenario=scenario, effect=effect, seed=seed, verdict=result.verdict, error=err["median"],
                why="; ".join(c.name for c in result.checks.failed), seconds=time.perf_counter() - t0)


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


def rates(rows) -> tuple[list[str], dict]:
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
            f"[{100 * dlo:.1f}, {100 * dhi:.1f}] (target ≥ 90 %); without gravity (a torque −mgl·sin y that is a "
            f"stiffness change by construction): {det_ng}/{len(no_gravity)}.",
            f"- Trials with effects whose stiffness is still right (error ≤ {FITS:.0%}) flagged anyway: "
            f"{flagged_accurate}/{len(accurate)} (not a false alarm: the model misses part of the torque, "
            "and the verdict says so).",
            f"- Analyses that failed outright (a clear error instead of a number): {len(failed)}."]
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


def main(seeds: int, jobs: int, duration: float) -> str:
    from limbstiff.simulate import SIMULATED_EFFECTS as EFFECTS, SCENARIOS as KNOWN
    scenarios = [s for s in LIMBS + PAPER if s in KNOWN]
    work = [(sc, eff, seed, duration) for sc in scenarios for eff in ((None, *EFFECTS) if sc in LIMBS else (None,))
            for seed in range(1, seeds + 1)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(one, work, chunksize=2))
    wall = time.perf_counter() - t0
    summary, _ = rates(rows)
    lines = ["## Model checks and the verdict (`benchmarks/checks.py`)", "",
             f"{len(rows)} simulated trials of {duration:.0f} s ({', '.join(scenarios)}; clean and with each of the "
             f"{len(EFFECTS)} effects at its default size; seeds 1–{seeds}; default settings, m and b identified); "
             f"{wall / 60:.1f} min on {jobs} processes. Machine: {machine()}.", "", *summary, "",
             *table(rows), "", "### Real ankle trials (`protocols/reklab-ankle.toml`)", "", *real_rows()]
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--duration", type=float, default=20.0)
    args = parser.parse_args()
    text = main(args.seeds, args.jobs, args.duration)
    update_section("checks", text)
    print(text)
