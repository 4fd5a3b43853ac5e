"""The trial verdict on limbstiff's own simulator: false alarms and band widths (issue 46).

    python benchmarks/own_verdicts.py [--seeds 3] [--duration 30] [--label after]

The scenarios of ``accuracy.py`` (clean trials of limbstiff's own simulator, m and b identified,
the default Kalman estimator), seeds 100, 101, … as there: per trial the verdict and its reasons,
the course band's coverage of the truth, whether the ``median_stiffness`` interval holds the true
course's median, and the band's median width relative to the stiffness. Issue 46 asks that these
stay: the share said ``ok`` on clean trials (a check that fires there is a false alarm; the
``elbow-nonlinear`` scenario's stiffness does depend on the angle, so the angle reason is a
detection there) and bands no wider than 1.5 times today's. Each run's figures are kept in
``own_verdicts.json`` under its label (a new run of a label replaces it); the run labelled
``before`` gives each scenario's width ratio. The median's interval is compared with the true
course's median over the figure's own samples (:func:`trial_verdicts.verdict_fields`; from the
run ``limit 1`` on: before it, over the informed samples after the first 2 s).

Runtime: about 3–5 s per 30 s trial on one process (8 scenarios × 3 seeds: ~2 min).
Writes section ``own-verdicts`` of ``benchmarks/RESULTS.md`` and ``benchmarks/own_verdicts.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from _results import machine, update_section  # noqa: E402
from accuracy import SCENARIOS  # noqa: E402
from trial_verdicts import summarise, summary_table, verdict_fields  # noqa: E402


def run_one(name: str, seed: int, duration: float) -> dict:
    """One clean trial of scenario ``name`` analysed with the defaults."""
    from limbstiff.analysis import analyze
    from limbstiff.simulate import simulate
    scenario, params, _ = SCENARIOS[name]
    trial = simulate(scenario, seed=seed, params=dict(params, duration=duration))
    t0 = time.perf_counter()
    result = analyze(trial, seed=seed)
    err = result.reference_error()
    fields = verdict_fields(result)
    from accuracy import trial_level_inside
    inside = trial_level_inside(result)
    fields["median_holds"] = None if inside is None else bool(inside[0])   # the true course's median
    return dict(scenario=name, seed=seed, verdict=str(result.verdict), error=err["median"],
                failed_checks=[c.name for c in result.checks.failed], seconds=time.perf_counter() - t0, **fields)


def width_rows(rows, before) -> list[str]:
    """Each scenario's median relative band width, against the stored ``before`` rows."""
    out = ["| scenario | band width / stiffness (median over seeds) | before | ratio | verdicts | failed checks |",
           "|---|---|---|---|---|---|"]
    ratios = []
    for name in SCENARIOS:
        now = [r["band_width"] for r in rows if r["scenario"] == name]
        old = [r["band_width"] for r in before or [] if r["scenario"] == name]
        ratio = float(np.median(now) / np.median(old)) if old else None
        ratios += [] if ratio is None else [ratio]
        verdicts = "/".join(str(sum(r["verdict"] == v for r in rows if r["scenario"] == name))
                            for v in ("ok", "caution", "unreliable"))
        failed = sorted({c for r in rows if r["scenario"] == name for c in r["failed_checks"]})
        out.append(f"| {name} | {np.median(now):.4f} | {'—' if not old else f'{np.median(old):.4f}'} | "
                   f"{'—' if ratio is None else f'{ratio:.2f}'} | {verdicts} | {', '.join(failed) or '—'} |")
    if ratios:
        out += ["", f"Width ratio against before: median {np.median(ratios):.2f}, largest {max(ratios):.2f} "
                    "(target ≤ 1.5)."]
    return out


def main(argv=None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--label", default="after")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    rows = [run_one(name, 100 + s, args.duration) for name in SCENARIOS for s in range(args.seeds)]
    wall = time.perf_counter() - t0
    path = HERE / "own_verdicts.json"
    old = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    before = rows if args.label == "before" else old.get("before_runs")
    clean = [r for r in rows if r["scenario"] != "elbow-nonlinear"]
    groups = {"clean (angle-independent)": summarise(clean),
              "elbow-nonlinear": summarise([r for r in rows if r["scenario"] == "elbow-nonlinear"])}
    verdicts = dict(old.get("verdicts", {}), **{args.label: groups})       # earlier runs' rows kept
    lines = ["## The trial verdict on limbstiff's own simulator (`benchmarks/own_verdicts.py`)", "",
             f"The scenarios of `accuracy.py`, {args.duration:g} s, seeds {100}–{99 + args.seeds}, m and b identified, "
             f"Kalman estimator; {len(rows)} trials in {wall / 60:.1f} min. Machine: {machine()}. "
             "`elbow-nonlinear` has an angle-dependent stiffness: its angle reason is a detection; on the others "
             "any failed check is a false alarm. The median's interval is held against the true course's median "
             "over the figure's own samples; the rows before `limit 1` took it over the informed samples after the "
             "first 2 s.", "", *summary_table(verdicts, truth="the true median"), "",
             *width_rows(rows, before)]
    text = "\n".join(lines)
    update_section("own-verdicts", text)
    path.write_text(json.dumps(dict(settings=vars(args), runs=rows, verdicts=verdicts, before_runs=before),
                               indent=1, default=float), encoding="utf-8")
    return text


if __name__ == "__main__":
    print(main())
