"""Stretch reflexes on a position-controlled joint: does the stiffness or the verdict say so?

    python benchmarks/reflex_study.py [--seeds 3] [--jobs 2] [--gains 0,2,4,6,8,10]
                                      [--duration 60] [--direction 1] [--quick]

The trials come from a generator of this study's own (``benchmarks/generators/gated_reflex.py``),
written from the published design of Guarín & Kearney (Frontiers 2020) and independent of
limbstiff's simulator and equations:

* one-DOF joint, K = 30 N·m/rad, B = 0.8 N·m·s/rad, I = 0.012 kg·m²;
* the angle is prescribed (a position-controlled actuator): random ±0.03 rad levels, a new
  independent random sign every 200 ms, low-passed by a continuous 4th-order Butterworth at
  30 Hz. The filter's state is propagated exactly (matrix exponential; the input is constant
  between switches), and θ, θ̇ = C·A·x, θ̈ = C·A²·x are exact (C·B = C·A·B = 0 for a filter of
  relative degree 4), on a 10 kHz grid;
* reflex torque r = s·G·d·max(d·θ̇(t − 40 ms) − 0.5 rad/s, 0), passed through the activation
  ω²/(s² + 2ζωs + ω²), ω = 15.6 rad/s, ζ = 0.62 (unit DC gain, first-order-hold discretisation
  at 10 kHz); s = +1 ("resisting": the actuator must push harder against a stretch) or −1
  ("published" sign); d = ±1 the stretch direction (``--direction``, default +1);
* measured torque = I·θ̈ + B·θ̇ + K·θ + r + white Gaussian noise at 15 dB SNR (noise RMS =
  RMS of the noise-free torque / 10^(15/20)); measured angle quantised by an encoder of
  2^16 counts per revolution (9.6e-5 rad); both sampled at 1 kHz from the 10 kHz grid.

One seed gives the same perturbation and the same standard-normal noise draws at every gain and
sign (common random numbers). Gain 0 is run once (sign "none"). Each trial is analysed four
ways (modes): m and b identified; m and b given (truth); the same two with ``effects=("reflex",)``
(recorded "not available" when ``analyze`` has no ``effects`` keyword). The stiffness error is
checks.py's: ``result.reference_error()["median"]``, the median over the informed samples after
2 s of |σ̂ − 30|/30; the median stiffness is ``result.informed_stiffness()[0].median``. A plain
least-squares fit torque ~ I·θ̈ + B·θ̇ + K·θ + c on the exact kinematics is shown beside the
paper's least-squares K, as a check of the generator.

Runtime (measured at HEAD 774992c, one process, 2-core machine): one 60 s trial in mode 1
(m, b identified by emcee) takes 4.4–5.5 s of CPU (5–6.5 s wall), mode 2 (m, b given) 1.3 s.
The full default study is 33 trials (gain 0 once, gains 2–10 × two signs, 3 seeds) × 4 modes
= 132 runs: modes 1–2 about 33 × 6 s = 200 s of CPU; the reflex modes are not timed (the
keyword does not exist yet) — at 1–3 times modes 1–2 the whole study takes about 3.5–7 min
with ``--jobs 2`` (plus ~10 s of least squares). ``--quick`` (1 seed, gains 0, 6, 10, 20 s)
takes under a minute and only prints.

Issue 46's figures of the verdict are added per run (:mod:`trial_verdicts`): the course band's
coverage of 30, whether the ``median_stiffness`` interval holds 30, the reasons and whether the
stiffness was said to depend on the angle; summarised per mode. A run with ``--label before``
keeps its summary (and its runs) in the JSON; later runs show it beside theirs.

Writes section ``reflex-study`` of ``benchmarks/RESULTS.md`` and ``benchmarks/reflex_study.json``.
"""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from _results import machine, update_section  # noqa: E402

from benchmarks.generators.gated_reflex import (  # noqa: E402  (the generator, shared)
    AMPLITUDE, B_TRUE, CORNER_HZ, DELAY_S, FS, I_TRUE, K_TRUE, OMEGA, ORDER, SIGNS, SNR_DB, SWITCH_S, THRESHOLD,
    ZETA)
from benchmarks.generators.gated_reflex import generate as _generate  # noqa: E402
from trial_verdicts import summarise, summary_table, verdict_fields  # noqa: E402

MODES = ("identified", "given", "identified+reflex", "given+reflex")
#: Guarín & Kearney's least-squares K (published sign), by reflex gain.
PAPER_LS = {0: 30.0, 2: 24.9, 4: 19.8, 6: 14.5, 8: 9.7, 10: 4.5}
WRONG, CLOSE = 0.20, 0.10


def generate(gain: float, sign: int, seed: int, duration: float, direction: int = 1) -> dict:
    """One trial of the design (:func:`benchmarks.generators.gated_reflex.generate`) from
    ``numpy.random.default_rng(seed)``."""
    return _generate(gain, sign, np.random.default_rng(seed), duration, direction)


def make_trial(gain: float, sign_name: str, seed: int, duration: float, direction: int = 1):
    """The generated trial as a :class:`limbstiff.trial.Trial` with ``stiffness_true`` = 30."""
    from limbstiff.trial import Trial
    g = generate(gain, SIGNS.get(sign_name, 1), seed, duration, direction)
    meta = {"generator": "benchmarks/generators/gated_reflex.py (Guarín & Kearney 2020 design)",
            "reflex_gain": f"{gain:g}", "reflex_sign": sign_name, "direction": str(direction),
            "seed": str(seed)}
    trial = Trial(name=f"reflex-{sign_name}-G{gain:g}-s{seed}", time=g["time"], angle=g["angle"],
                  torque=g["torque"], stiffness_true=np.full(len(g["time"]), K_TRUE), metadata=meta)
    return trial, g


def least_squares(g: dict) -> dict:
    """Plain least squares torque ~ I·θ̈ + B·θ̇ + K·θ + c on the exact kinematics."""
    x = np.column_stack([g["acceleration"], g["velocity"], g["theta"], np.ones_like(g["theta"])])
    (i, b, k, c), *_ = np.linalg.lstsq(x, g["torque"], rcond=None)
    return dict(K=float(k), B=float(b), I=float(i), c=float(c))


def _interval(iv) -> dict | None:
    """An Interval as a dict (None stays None)."""
    return None if iv is None else dict(median=float(iv.median), lo=float(iv.lo), hi=float(iv.hi))


def _number(value):
    """A float when the value is a number, its text otherwise (for the JSON)."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def _effects(result) -> list:
    """The effects the identification found (empty when the library has none)."""
    found = getattr(result.identification, "effects", None) or ()
    return [dict(name=str(e.name), shape={str(k): _number(v) for k, v in dict(e.shape or {}).items()},
                 amplitude=None if getattr(e, "amplitude", None) is None else _interval(e.amplitude))
            for e in found]


def _fill(row: dict, result) -> None:
    """Add an analysis's figures to its row."""
    err = result.reference_error()
    median, _, _ = result.informed_stiffness()
    m, b = result.inertia, result.damping
    row.update(verdict=result.verdict, failed_checks=[c.name for c in result.checks.failed],
               median_stiffness=float(median.median), error=None if err is None else err["median"],
               inertia=_interval(m), damping=_interval(b),
               inertia_error=None if m is None else abs(m.median - I_TRUE) / I_TRUE,
               damping_error=None if b is None else abs(b.median - B_TRUE) / B_TRUE,
               effects=_effects(result), **verdict_fields(result, K_TRUE))


def run_one(job: dict) -> dict:
    """Analyse one trial in one mode (a process-pool task); never raises for a failed analysis."""
    from limbstiff.analysis import analyze
    from limbstiff.errors import LimbstiffError
    row = dict(job, verdict=None, failed_checks=[], median_stiffness=None, error=None, inertia=None,
               damping=None, inertia_error=None, damping_error=None, effects=[], message=None)
    cpu, wall = time.process_time(), time.perf_counter()
    trial, _ = make_trial(job["gain"], job["sign"], job["seed"], job["duration"], job["direction"])
    kwargs = dict(seed=job["seed"])
    if job["mode"].startswith("given"):
        kwargs.update(inertia=I_TRUE, damping=B_TRUE)
    if job["mode"].endswith("+reflex"):
        kwargs.update(effects=("reflex",))
    try:
        result = analyze(trial, **kwargs)
    except LimbstiffError as exc:
        row.update(verdict="failed", message=f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}")
    except Exception as exc:  # noqa: BLE001 - a crash is a result of the study too, said as such
        row.update(verdict="failed", message=f"crash {type(exc).__name__}: {' '.join(str(exc).split())[:200]}")
    else:
        try:
            _fill(row, result)
        except Exception as exc:  # noqa: BLE001 - the analysis ran; the harness could not read all of it
            row.update(verdict=row["verdict"] or result.verdict,
                       message=f"harness could not read the result: {type(exc).__name__}: {exc}"[:200])
    row.update(cpu_s=time.process_time() - cpu, wall_s=time.perf_counter() - wall)
    return row


def effects_available() -> bool:
    """Whether ``analyze`` takes the ``effects`` keyword."""
    from limbstiff.analysis import analyze
    return "effects" in inspect.signature(analyze).parameters


def plan(gains, seeds: int, duration: float, direction: int) -> list[dict]:
    """Every (sign, gain, seed, mode) run; gain 0 once, with sign ``none``."""
    cases = [("none", g) if g == 0 else (s, g) for g in gains for s in (SIGNS if g else ("none",))]
    return [dict(sign=s, gain=float(g), seed=seed, mode=mode, duration=duration, direction=direction)
            for s, g in cases for seed in range(1, seeds + 1) for mode in MODES]


def _span(values, fmt: str = "{:.1f}") -> str:
    """``median (min–max)`` of the values that are not None, or a dash."""
    values = [v for v in values if v is not None]
    if not values:
        return "—"
    return f"{fmt.format(np.median(values))} ({fmt.format(min(values))}–{fmt.format(max(values))})"


def _pct(values) -> str:
    """Median of the relative errors that are not None, in per cent, or a dash."""
    values = [v for v in values if v is not None]
    return f"{100 * np.median(values):.1f} %" if values else "—"


def groups(rows) -> dict:
    """Rows by (sign, gain, mode), in the study's order."""
    out = {}
    for r in rows:
        out.setdefault((r["sign"], r["gain"], r["mode"]), []).append(r)
    return out


def study_table(rows) -> list[str]:
    """One line per (sign, gain, mode): stiffness, verdicts, m and b errors, reflex amplitude."""
    out = ["| sign | G | mode | median K, N·m/rad (min–max) | error (checks.py) | verdicts ok/caution/unreliable/failed "
           "| m error | b error | reflex amplitude | failed checks (most often) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (sign, gain, mode), rs in groups(rows).items():
        if all(r["verdict"] == "not available" for r in rs):
            out.append(f"| {sign} | {gain:g} | {mode} | not available | | | | | | |")
            continue
        c = Counter(r["verdict"] for r in rs)
        amps = [e["amplitude"]["median"] for r in rs for e in r["effects"] if e["name"] == "reflex" and e["amplitude"]]
        why = Counter(n for r in rs for n in r["failed_checks"])
        fails = [r["message"] for r in rs if r["verdict"] == "failed"]
        reasons = ", ".join(f"{k} {v}" for k, v in why.most_common(2)) or (fails[0] if fails else "—")
        given = mode.startswith("given")
        out.append(f"| {sign} | {gain:g} | {mode} | {_span([r['median_stiffness'] for r in rs])} | "
                   f"{_pct([r['error'] for r in rs])} | {c['ok']}/{c['caution']}/{c['unreliable']}/{c['failed']} | "
                   f"{'given' if given else _pct([r['inertia_error'] for r in rs])} | "
                   f"{'given' if given else _pct([r['damping_error'] for r in rs])} | {_span(amps, '{:.3g}')} | {reasons} |")
    return out


def criteria(rows) -> list[str]:
    """The issue's pass criteria, counted."""
    done = [r for r in rows if r["verdict"] not in ("not available",)]
    silent = [r for r in done if r["error"] is not None and r["error"] > WRONG and r["verdict"] == "ok"]
    by_mode = Counter(r["mode"] for r in silent)
    reflex = [r for r in rows if r["mode"].endswith("+reflex")]
    out = [f"- (a) runs with median error > {100 * WRONG:.0f} % and verdict `ok`: **{len(silent)}** of {len(done)} analysed "
           f"runs (target 0){'; by mode: ' + ', '.join(f'{k} {v}' for k, v in by_mode.items()) if silent else ''}."]
    if all(r["verdict"] == "not available" for r in reflex):
        out += ["- (b) with the reflex in the model: not available (`analyze` has no `effects` keyword).",
                "- (c) m and b within 10 % with the reflex in the model: not available."]
        return out
    able = [r for r in reflex if r["verdict"] not in ("failed", "not available")]
    close = [r for r in able if r["error"] is not None and r["error"] <= CLOSE]
    ident = [r for r in reflex if r["mode"] == "identified+reflex" and r["verdict"] not in ("failed", "not available")]
    both = [r for r in ident if r["inertia_error"] is not None and r["inertia_error"] <= CLOSE
            and r["damping_error"] is not None and r["damping_error"] <= CLOSE]
    failed = sum(r["verdict"] == "failed" for r in reflex)
    out += [f"- (b) with the reflex in the model, runs within {100 * CLOSE:.0f} % of the truth: **{len(close)}/{len(able)}** "
            f"analysable runs ({failed} failed outright).",
            f"- (c) identified mode with the reflex, m and b both within {100 * CLOSE:.0f} %: **{len(both)}/{len(ident)}** "
            f"(m alone {sum(r['inertia_error'] <= CLOSE for r in ident if r['inertia_error'] is not None)}, "
            f"b alone {sum(r['damping_error'] <= CLOSE for r in ident if r['damping_error'] is not None)})."]
    return out


def least_squares_rows(cases, seeds: int, duration: float, direction: int) -> list[dict]:
    """The plain least-squares fit of every generated trial (sign, gain, seed)."""
    rows = []
    for sign, gain in cases:
        for seed in range(1, seeds + 1):
            _, g = make_trial(gain, sign, seed, duration, direction)
            fit = least_squares(g)
            rows.append(dict(sign=sign, gain=gain, seed=seed, **fit,
                             reflex_rms=float(np.sqrt(np.mean(g["reflex"] ** 2))),
                             torque_rms=float(np.sqrt(np.mean(g["torque"] ** 2))),
                             peak_velocity=float(np.max(np.abs(g["velocity"])))))
    return rows


def least_squares_table(ls_rows) -> list[str]:
    """Own least-squares K, B, I beside the paper's K (published sign)."""
    out = ["| sign | G | own LS K, N·m/rad (min–max) | own LS B | own LS I | reflex RMS / measured torque RMS | paper LS K (published sign) |",
           "|---|---|---|---|---|---|---|"]
    keys = []
    for r in ls_rows:
        if (r["sign"], r["gain"]) not in keys:
            keys.append((r["sign"], r["gain"]))
    for sign, gain in keys:
        rs = [r for r in ls_rows if (r["sign"], r["gain"]) == (sign, gain)]
        paper = PAPER_LS.get(int(gain)) if sign in ("published", "none") and gain == int(gain) else None
        out.append(f"| {sign} | {gain:g} | {_span([r['K'] for r in rs])} | {_span([r['B'] for r in rs], '{:.2f}')} | "
                   f"{_span([r['I'] for r in rs], '{:.4f}')} | "
                   f"{100 * np.median([r['reflex_rms'] / r['torque_rms'] for r in rs]):.0f} % | "
                   f"{'—' if paper is None else f'{paper:g}'} |")
    return out + ["", ls_agreement(ls_rows)]


def ls_agreement(ls_rows) -> str:
    """One sentence: the published-sign least-squares K against the paper's, as slopes per unit gain."""
    pts = [(r["gain"], r["K"]) for r in ls_rows if r["sign"] in ("published", "none")]
    gains = sorted({g for g, _ in pts if g in PAPER_LS})
    if len(gains) < 2:
        return "(too few gains to compare the least squares with the paper's)"
    own = [float(np.median([k for g, k in pts if g == gain])) for gain in gains]
    slope, paper_slope = np.polyfit(gains, own, 1)[0], np.polyfit(gains, [PAPER_LS[g] for g in gains], 1)[0]
    worst = max(abs(o - PAPER_LS[g]) for g, o in zip(gains, own))
    return (f"Published sign, gains {', '.join(f'{g:g}' for g in gains)}: own least-squares K falls by "
            f"{-slope:.2f} N·m/rad per N·m·s/rad of reflex gain, the paper's by {-paper_slope:.2f} "
            f"({100 * slope / paper_slope:.0f} % of it); largest difference {worst:.1f} N·m/rad. "
            + ("The generator reproduces the published bias." if abs(slope / paper_slope - 1) <= 0.1 and worst <= 2
               else "The generator reproduces the direction and linearity of the published bias, not its size "
                    "(the design summary leaves the perturbation's switching statistics and filter open)."))


def run(gains, seeds: int, jobs: int, duration: float, direction: int) -> tuple[list, list, float, bool]:
    """Every run of the study (the unavailable ones recorded, not run), and the least squares."""
    available = effects_available()
    work = plan(gains, seeds, duration, direction)
    todo = [j for j in work if available or not j["mode"].endswith("+reflex")]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        done = list(pool.map(run_one, todo, chunksize=1))
    wall = time.perf_counter() - t0
    skipped = [dict(j, verdict="not available", failed_checks=[], median_stiffness=None, error=None,
                    inertia=None, damping=None, inertia_error=None, damping_error=None, effects=[],
                    message="analyze() has no 'effects' keyword", cpu_s=0.0, wall_s=0.0)
               for j in work if j not in todo]
    order = {(j["sign"], j["gain"], j["seed"], j["mode"]): k for k, j in enumerate(work)}
    rows = sorted(done + skipped, key=lambda r: order[(r["sign"], r["gain"], r["seed"], r["mode"])])
    cases = list(dict.fromkeys((j["sign"], j["gain"]) for j in work))
    return rows, least_squares_rows(cases, seeds, duration, direction), wall, available


#: The groups of runs issue 46's figures are given for: each mode, and m and b identified and given.
SUMMARY_GROUPS = {"identified": ("identified",), "identified+reflex": ("identified+reflex",),
                  "given": ("given",), "given+reflex": ("given+reflex",),
                  "all with --effect reflex": ("identified+reflex", "given+reflex"),
                  "all without": ("identified", "given")}


def summaries(rows) -> dict:
    """Issue 46's figures (:func:`trial_verdicts.summarise`) of each of :data:`SUMMARY_GROUPS`."""
    return {name: summarise([r for r in rows if r["mode"] in modes]) for name, modes in SUMMARY_GROUPS.items()}


def verdict_section(current: dict, stored: dict, label: str) -> list[str]:
    """The table of issue 46's figures: the stored labels (the code before a change) and this run's."""
    labels = {k: v for k, v in stored.items() if k != label}
    labels[label] = current
    return ["### Trial verdicts: does `ok` mean the band holds 30? (issue 46)", "",
            "Course coverage = share of the informed samples after 2 s whose band holds 30, pooled over the runs "
            "said `ok` (the samples are correlated: its Wilson interval is too narrow); per trial: the median "
            "(min) of each `ok` run's coverage. Median interval = `trial_level.median_stiffness` at 90 %. "
            "The last column counts the runs whose reasons say the joint's stiffness depends on its angle "
            "(the gated reflex must not), and those whose angle check failed with any reason.", "",
            *summary_table(labels)]


def report(rows, ls_rows, wall: float, available: bool, args, stored: dict | None = None) -> str:
    """The ``reflex-study`` section of RESULTS.md."""
    cpu = [r["cpu_s"] for r in rows if r["verdict"] != "not available"]
    lines = ["## Stretch reflexes on a position-controlled joint (`benchmarks/reflex_study.py`)", "",
             f"Own generator after Guarín & Kearney (2020): K {K_TRUE:g} N·m/rad, B {B_TRUE:g} N·m·s/rad, "
             f"I {I_TRUE:g} kg·m²; prescribed angle, random ±{AMPLITUDE:g} rad levels switched every "
             f"{1000 * SWITCH_S:.0f} ms through a {ORDER}th-order {CORNER_HZ:g} Hz Butterworth; reflex from the velocity "
             f"{1000 * DELAY_S:.0f} ms earlier above {THRESHOLD:g} rad/s, activation ω {OMEGA:g} rad/s, ζ {ZETA:g}; torque "
             f"noise {SNR_DB:g} dB SNR, encoder 2^16 counts/rev; {args.duration:g} s at {FS:g} Hz, direction "
             f"{args.direction:+d}, seeds 1–{args.seeds}. {len(cpu)} runs analysed "
             f"({'the reflex modes included' if available else 'the reflex modes not available: analyze() has no effects keyword'}); "
             f"{wall / 60:.1f} min on {args.jobs} processes, CPU per run {np.median(cpu) if cpu else float('nan'):.1f} s "
             f"(median). Machine: {machine()}.", "",
             "Error = checks.py's definition (`reference_error()['median']`: median over the informed samples after "
             "2 s of |σ̂ − 30|/30); median K = `informed_stiffness()`; m and b errors = |median − truth|/truth, "
             "medians over seeds.", "", *criteria(rows), "", *study_table(rows), "",
             "### Plain least squares on the generator's exact kinematics (a check of the generator)", "",
             *least_squares_table(ls_rows), "", *verdict_section(summaries(rows), stored or {}, args.label)]
    return "\n".join(lines)


def main(argv=None) -> str:
    """Parse the command line, run the study, write RESULTS.md's section and the JSON; return the section."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, help="seeds per (sign, gain) (default 3)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--gains", help="reflex gains, N·m·s/rad (default 0,2,4,6,8,10)")
    parser.add_argument("--duration", type=float, help="trial length, s (default 60)")
    parser.add_argument("--direction", type=int, choices=(1, -1), default=1)
    parser.add_argument("--label", default="after",
                        help="name of this run's figures in the JSON's `verdicts` (earlier labels are kept)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: 1 seed, gains 0,6,10, 20 s (unless given explicitly)")
    args = parser.parse_args(argv)
    preset = (1, "0,6,10", 20.0) if args.quick else (3, "0,2,4,6,8,10", 60.0)
    for name, value in zip(("seeds", "gains", "duration"), preset):
        if getattr(args, name) is None:
            setattr(args, name, value)
    gains = [float(g) for g in args.gains.split(",")]
    rows, ls_rows, wall, available = run(gains, args.seeds, args.jobs, args.duration, args.direction)
    path = HERE / "reflex_study.json"
    old = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    # every earlier labelled run is kept (a run of the same label replaces it)
    stored = {} if args.quick else {k: v for k, v in old.get("verdicts", {}).items() if k != args.label}
    text = report(rows, ls_rows, wall, available, args, stored)
    verdicts = dict(stored, **{args.label: summaries(rows)})
    if args.quick:
        print(text)
        return text
    update_section("reflex-study", text)
    path.write_text(json.dumps(
        dict(settings=vars(args), effects_available=available, wall_s=wall, runs=rows, least_squares=ls_rows,
             verdicts=verdicts, before_runs=old.get("before_runs", rows if args.label == "before" else None)),
        indent=1, default=float), encoding="utf-8")
    return text


if __name__ == "__main__":
    print(main())
