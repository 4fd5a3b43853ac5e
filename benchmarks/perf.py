"""Speed and memory of limbstiff as ratios measured in one run, by CPU time (issue 37).

    python benchmarks/perf.py [--quick] [--only PART[,PART...]]

Parts (``--only`` runs some of them, prints their tables and leaves RESULTS.md alone):

``passes``
    One estimator pass on 10⁶ samples ÷ one ``numpy.cumsum`` over 10⁶ float64 (target ≤ 10): the
    observer (exact and Euler, forwards and backwards, as the estimators run it; the pure-NumPy
    blocked scan used without numba) and the Kalman filter + RTS smoother.
``bands``
    Bands from 2000 posterior draws ÷ one estimator pass (target ≤ 3).
``analysis``
    In-process ``analyze(trial, seed=0)`` of a 60 s elbow ÷ one Kalman filter + RTS smoother pass
    over the same trial at every sample (target ≤ 100), and its PDF report ÷ the analysis (≤ 0.4).
``length``
    ``analyze`` CPU against trial length, 10 s to 1 hour (``--quick``: 10 min), fitted exponent.
    ``--quick`` also takes one run per length from 100 s (the full run: the median of 3 up to 100 s).
``process``
    Whole processes: ``python -m limbstiff analyze FILE --jobs 1`` with its PDF (and with
    ``--no-pdf``) ÷ ``python benchmarks/ls_baseline.py FILE OUT``, the windowed least-squares
    script a lab would write, on a 60 s elbow (target ≤ 1.5) and a 10 s elbow (≤ 2); and
    ``limbstiff diagnose FILE --no-pdf`` ÷ ``limbstiff analyze FILE --no-pdf`` on the 60 s elbow
    (≤ 1.5).
``long``
    A one-hour 1 kHz trial (``--quick``: 10 min) read, analysed and reported in a fresh process:
    peak resident memory (VmHWM, target ≤ 1 GB, read as 1000 MB), its analysis ÷ one Kalman pass
    over it (≤ 100) and its report ÷ its analysis (≤ 0.4).
``batch``
    ``limbstiff analyze FOLDER --jobs 2`` ÷ ``--jobs 1`` on 8 trials of 60 s (``--quick``: 4),
    by wall time: the ratio is about parallelism (target ≤ 0.6).

How measured: CPU time, never the best of several wall times (the machine is shared and has 2
cores). In-process, ``time.process_time`` (every thread of this process), the median of several
calls; a whole process, the user + system time of the child (``resource.getrusage`` of
``RUSAGE_CHILDREN`` before and after ``subprocess.run``), the commands alternating round by round
and the median of each taken, after unmeasured runs of ``analyze`` and ``diagnose`` that fill
numba's on-disk cache.
Writes section ``perf`` of ``benchmarks/RESULTS.md`` (ratios first, then the details).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _results import machine, update_section  # noqa: E402

from limbstiff.analysis import analyze  # noqa: E402
from limbstiff.estimate import estimators, observer, scan  # noqa: E402
from limbstiff.files import write_trial  # noqa: E402
from limbstiff.filtered import filter_trial  # noqa: E402
from limbstiff.protocol import Protocol  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402
from limbstiff.statespace import kernels  # noqa: E402
from limbstiff.statespace.noise import NoiseLevels  # noqa: E402
from limbstiff.statespace.smoother import kalman_smoother  # noqa: E402
from limbstiff.statespace.steps import deflection  # noqa: E402

N = 1_000_000
PARTS = ("passes", "bands", "analysis", "length", "process", "long", "batch")
LIMBSTIFF = [sys.executable, "-m", "limbstiff"]
BASELINE = [sys.executable, str(HERE / "ls_baseline.py")]
SCENARIOS = ("elbow", "wrist", "ankle")


def cpu(func) -> float:
    """CPU seconds (every thread of this process) of one call of ``func``."""
    start = time.process_time()
    func()
    return time.process_time() - start


def median_cpu(func, repeats: int = 7) -> float:
    """Median CPU seconds of ``repeats`` calls of ``func``."""
    return statistics.median(cpu(func) for _ in range(repeats))


def child(cmd: list[str], cwd: Path) -> tuple[float, float]:
    """CPU seconds (user + system, the child and what it waited for) and wall seconds of a command.

    Raises
    ------
    RuntimeError
        If the command fails (the end of its standard error in the message).
    """
    before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall


def alternate(commands: dict[str, list[str]], rounds: int, cwd: Path, warm: tuple[str, ...] = ()
              ) -> dict[str, dict[str, float]]:
    """Run the ``warm`` commands once unmeasured, then ``rounds`` rounds of all of them in turn.

    Returns
    -------
    dict
        Per command, the median ``cpu`` and ``wall`` seconds and the ``cpus`` of every round.
    """
    for name in warm:
        child(commands[name], cwd)
    runs = {name: [] for name in commands}
    for _ in range(rounds):
        for name, cmd in commands.items():
            runs[name].append(child(cmd, cwd))
    return {name: {"cpu": statistics.median(c for c, _ in r), "wall": statistics.median(w for _, w in r),
                   "cpus": [c for c, _ in r]} for name, r in runs.items()}


def kalman_of(sig, inertia: float, damping: float, loglik: bool = True):
    """A function running one Kalman filter + RTS smoother pass over ``sig`` at every sample."""
    ts = sig.sample_period
    z = sig.elastic_torque(inertia, damping)
    d = np.diff(sig.angle, prepend=sig.angle[0])
    noise = NoiseLevels(1e-2, 1e-1, 1.0, 1.0)
    kw = dict(step=ts, deflection=deflection(sig.angle, step=ts, motion_frequency=sig.motion_hz),
              initial_mean=np.array([z[0], 60.0]), initial_cov=np.array([1.0, 0.0, 1e4]))
    return lambda: kalman_smoother(d, z, noise, loglik=loglik, **kw)


def kalman_of_trial(trial):
    """One Kalman pass over ``trial``'s filtered signals at its nominal inertia and damping."""
    meta = trial.metadata
    return kalman_of(filter_trial(trial, Protocol()), float(meta.get("nominal_inertia", 0.015)),
                     float(meta.get("nominal_damping", 1.0)))


def million():
    """The filtered signals of a simulated ankle trial of 10⁶ samples."""
    return filter_trial(simulate("ankle", seed=0, params={"duration": N / 1000.0 - 0.001}), Protocol())


def passes(sig) -> dict:
    """CPU seconds of one pass of each estimator over ``sig`` (10⁶ samples), and of one cumsum."""
    m, b, ts = 0.015, 1.0, sig.sample_period
    drive = observer.external_drive(sig.torque_rate, sig.acceleration, sig.jerk, inertia=m, damping=b)
    x = np.random.default_rng(0).standard_normal(N)
    t_cumsum = median_cpu(lambda: np.cumsum(x), 31)
    out = []
    for disc in ("exact", "euler"):
        gain = 0.5 if disc == "euler" else 300.0       # Euler needs α·|ẏ|·Ts < 2 to stay stable
        for direction, sl in (("forwards", slice(None)), ("backwards", slice(None, None, -1))):
            vel, drv = np.ascontiguousarray(sig.velocity[sl]), np.ascontiguousarray(drive[sl])
            out.append((f"observer, {disc}, {direction} (coefficients in NumPy, compiled recursion: "
                        "as the estimators run it)",
                        median_cpu(lambda disc=disc, gain=gain, vel=vel, drv=drv: observer.observe(
                            vel, drv, observer_gain=gain, sample_period=ts, discretisation=disc))))

    def numpy_pass():
        a, c = observer.recursion_coefficients(sig.velocity, drive, observer_gain=300.0, sample_period=ts)
        return scan.linear_recursion(a, c)
    out.append(("observer, exact, pure NumPy (coefficients + blocked scan; the reference path)",
                median_cpu(numpy_pass)))
    a, c = observer.recursion_coefficients(sig.velocity, drive, observer_gain=300.0, sample_period=ts)
    out.append(("  the recursion alone, compiled", median_cpu(lambda: kernels.linear_recursion(a, c, 0.0), 15)))
    out.append(("  the recursion alone, NumPy blocked scan", median_cpu(lambda: scan.linear_recursion(a, c))))
    out.append(("Kalman filter + RTS smoother, every sample, with the log-likelihood", median_cpu(kalman_of(sig, m, b))))
    out.append(("Kalman filter + RTS smoother, every sample (the responses to ÿ and ẏ: no log-likelihood)",
                median_cpu(kalman_of(sig, m, b, loglik=False))))
    out.append(("Kalman estimator as analyze runs it: steps at 2.5× the corner, σ̂ and its two "
                "sensitivities, back to every sample",
                median_cpu(lambda: estimators.kalman(sig, inertia=m, damping=b, noise=NoiseLevels(1e-2, 1e-1, 1.0, 1.0)),
                           5)))
    return {"rows": out, "cumsum": t_cumsum}


def bands(sig) -> dict:
    """CPU seconds of bands from 2000 draws of (m, b) against one observer pass."""
    kw = dict(smoothed=False, gain=300.0, velocity_threshold=0.0)
    est = estimators.observers(sig, inertia=0.015, damping=1.0, **kw)
    t_three = median_cpu(lambda: estimators.observers(sig, inertia=0.015, damping=1.0, **kw), 5)
    draws = np.random.default_rng(0).multivariate_normal([0.015, 1.0], [[1e-8, 0], [0, 1e-4]], 2000)
    t_cov = median_cpu(lambda: est.variance_with(np.cov(draws.T)), 9)
    t_pass = t_three / 3                          # σ̂, ∂σ̂/∂m, ∂σ̂/∂b: three passes
    return {"pass": t_pass, "given_sensitivities": t_cov, "with_sensitivities": t_cov + 2 * t_pass,
            "naive": 2000 * t_pass}


def analysis(trial, folder: Path, repeats: int = 3) -> dict:
    """Median CPU of ``analyze`` and of its PDF report, and of one Kalman pass between them.

    Each analysis is followed by its report and by three Kalman passes over the same trial, so the
    two are measured alternately under the same load.
    """
    from limbstiff.report import write_report
    kalman = kalman_of_trial(trial)
    runs, passes_ = [], [cpu(kalman) for _ in range(3)]
    for _ in range(repeats):
        start = time.process_time()
        result = analyze(trial, seed=0)
        middle = time.process_time()
        write_report(result, folder / f"{trial.name}.pdf")
        runs.append((middle - start, time.process_time() - middle))
        passes_ += [cpu(kalman) for _ in range(3)]
    a, r = (statistics.median(x) for x in zip(*runs))
    k = statistics.median(passes_)
    return {"analysis": a, "report": r, "kalman": k, "ratio": a / k, "report_ratio": r / a,
            "samples": trial.n_samples}


def length_study(lengths: list[float], up_to: float = 100.0) -> dict:
    """CPU of ``analyze`` (no report) of ankle trials of each length (median of 3 up to ``up_to`` s)."""
    rows = []
    for d in lengths:
        trial = simulate("ankle", seed=4, params={"duration": d})
        rows.append((d, median_cpu(lambda trial=trial: analyze(trial, seed=0), 3 if d <= up_to else 1)))
    x, y = np.log([d for d, _ in rows]), np.log([t for _, t in rows])
    return {"rows": rows, "slope": float(np.polyfit(x, y, 1)[0]), "upper": float(np.polyfit(x[2:], y[2:], 1)[0]),
            "up_to": up_to}


def process(folder: Path, rounds: int) -> dict:
    """Whole-process CPU of limbstiff against the least-squares baseline on a 60 s and a 10 s elbow."""
    out = {}
    folder.mkdir(parents=True, exist_ok=True)
    for duration in (60.0, 10.0):
        path = folder / f"elbow{duration:g}.csv"
        write_trial(simulate("elbow", seed=3, params={"duration": duration}), path)
        cmds = {"pdf": [*LIMBSTIFF, "analyze", str(path), "--out", str(folder / "pdf"), "--jobs", "1", "--overwrite"],
                "no_pdf": [*LIMBSTIFF, "analyze", str(path), "--out", str(folder / "nopdf"), "--jobs", "1",
                           "--overwrite", "--no-pdf"],
                "baseline": [*BASELINE, str(path), str(folder / "ls")]}
        if duration == 60.0:
            cmds["diagnose"] = [*LIMBSTIFF, "diagnose", str(path), "--out", str(folder / "diag"), "--jobs", "1",
                                "--overwrite", "--no-pdf"]
        # one unmeasured run of each limbstiff command on the first file fills numba's cache
        out[duration] = alternate(cmds, rounds, folder, warm=("pdf", "diagnose") if duration == 60.0 else ())
    return out


LONG_SCRIPT = """
import json, statistics, sys, time
sys.path.insert(0, sys.argv[3])

def peak_mb():
    # VmHWM: this process's own peak resident set (ru_maxrss would carry over the parent's
    # peak through fork and exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024

from limbstiff.files import read_trial
from limbstiff.analysis import analyze
from limbstiff.report import write_report
imports = peak_mb()
c0 = time.process_time()
trial = read_trial(sys.argv[1])
c1 = time.process_time()
result = analyze(trial, seed=0)
c2 = time.process_time()
write_report(result, sys.argv[1] + ".pdf")
c3 = time.process_time()
peak = peak_mb()                   # reading, analysing and reporting, before anything else runs
del result
import perf
kalman = perf.kalman_of_trial(trial)
analyses, passes = [c2 - c1], [perf.cpu(kalman) for _ in range(3)]
for _ in range(int(sys.argv[2]) - 1):
    analyses.append(perf.cpu(lambda: analyze(trial, seed=0)))
    passes += [perf.cpu(kalman) for _ in range(2)]
print(json.dumps({"imports_mb": imports, "peak_mb": peak, "read": c1 - c0, "report": c3 - c2,
                  "analyses": analyses, "kalman": statistics.median(passes), "samples": trial.n_samples}))
"""


def long_trial(duration: float, folder: Path, repeats: int = 3) -> dict:
    """Peak memory and CPU of a fresh process reading, analysing and reporting one long trial.

    The peak (VmHWM) covers reading, the first analysis and the report; then the same process
    analyses the trial ``repeats - 1`` more times and runs Kalman passes over it between them.
    """
    path = folder / "long.csv"
    write_trial(simulate("ankle", seed=5, params={"duration": duration}), path)
    warm = "import limbstiff.analysis, limbstiff.files, numpy, limbstiff.report; import limbstiff.statespace.kernels"
    subprocess.run([sys.executable, "-c", warm], check=True)
    done = subprocess.run([sys.executable, "-c", LONG_SCRIPT, str(path), str(repeats), str(HERE)],
                          capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"the long trial's process failed ({done.returncode}):\n{done.stderr[-3000:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["analysis"] = statistics.median(out["analyses"])
    out["ratio"], out["report_ratio"] = out["analysis"] / out["kalman"], out["report"] / out["analyses"][0]
    out["file_mb"] = path.stat().st_size / 2 ** 20
    return out


def batch(folder: Path, n_trials: int) -> dict:
    """Wall (and CPU) seconds of ``limbstiff analyze FOLDER`` with ``--jobs 1`` and ``--jobs 2``.

    Run in the order 1, 2, 2, 1 after one unmeasured single-trial run; medians of the two each.
    """
    trials = folder / "trials"
    trials.mkdir(parents=True)
    for i in range(n_trials):
        scenario = SCENARIOS[i % len(SCENARIOS)]
        write_trial(simulate(scenario, seed=i, params={"duration": 60.0}), trials / f"{scenario}-{i:03d}.csv")
    child([*LIMBSTIFF, "analyze", str(next(trials.glob("*.csv"))), "--out", str(folder / "warm"), "--jobs", "1"],
          folder)
    runs, loads = {1: [], 2: []}, []
    for jobs in (1, 2, 2, 1):
        loads.append(os.getloadavg()[0])
        runs[jobs].append(child([*LIMBSTIFF, "analyze", str(trials), "--out", str(folder / f"out{jobs}"),
                                 "--jobs", str(jobs), "--overwrite"], folder))
        assert len(list((folder / f"out{jobs}").glob("*/report.pdf"))) == n_trials
    med = {j: {"wall": statistics.median(w for _, w in r), "cpu": statistics.median(c for c, _ in r)}
           for j, r in runs.items()}
    return {"jobs": med, "ratio": med[2]["wall"] / med[1]["wall"], "trials": n_trials, "loads": loads}


def target_rows(res: dict, quick: bool) -> list[tuple[str, float, str, float, str]]:
    """(what, measured, comparison, target, unit) for every ratio of the parts that ran."""
    rows, long_name = [], "10-minute" if quick else "one-hour"
    if "passes" in res:
        kal = dict(res["passes"]["rows"])["Kalman filter + RTS smoother, every sample, with the log-likelihood"]
        rows.append(("Kalman filter + RTS smoother pass over 10⁶ samples ÷ one `numpy.cumsum`",
                     kal / res["passes"]["cumsum"], "≤", 10, ""))
    if "bands" in res:
        b = res["bands"]
        rows.append(("bands from 2000 draws, counting the two sensitivity passes, ÷ one observer pass",
                     b["with_sensitivities"] / b["pass"], "≤", 3, ""))
    if "process" in res:
        p60, p10 = res["process"][60.0], res["process"][10.0]
        rows += [("whole process, 60 s elbow with its PDF ÷ the least-squares script", p60["pdf"]["cpu"] / p60["baseline"]["cpu"], "≤", 1.5, ""),
                 ("whole process, 60 s elbow `--no-pdf` ÷ the least-squares script", p60["no_pdf"]["cpu"] / p60["baseline"]["cpu"], "", 0, ""),
                 ("whole process, 10 s elbow with its PDF ÷ the least-squares script", p10["pdf"]["cpu"] / p10["baseline"]["cpu"], "≤", 2, ""),
                 ("`limbstiff diagnose --no-pdf` ÷ `limbstiff analyze --no-pdf`, whole process, 60 s elbow",
                  p60["diagnose"]["cpu"] / p60["no_pdf"]["cpu"], "≤", 1.5, "")]
    if "analysis" in res:
        rows += [("analysis ÷ one Kalman filter + smoother pass over the same trial, 60 s elbow", res["analysis"]["ratio"], "≤", 100, ""),
                 ("PDF report ÷ analysis, 60 s elbow", res["analysis"]["report_ratio"], "≤", 0.4, "")]
    if "long" in res:
        lg = res["long"]
        rows += [(f"analysis ÷ one Kalman filter + smoother pass over the same trial, {long_name} trial", lg["ratio"], "≤", 100, ""),
                 (f"peak memory, {long_name} trial read, analysed and reported (fresh process)", lg["peak_mb"], "≤", 1000, " MB"),
                 (f"PDF report ÷ analysis, {long_name} trial", lg["report_ratio"], "≤", 0.4, "")]
    if "batch" in res:
        rows.append((f"batch of {res['batch']['trials']} trials of 60 s, `--jobs 2` ÷ `--jobs 1`, wall time",
                     res["batch"]["ratio"], "≤", 0.6, ""))
    return rows


def ratio_lines(res: dict, quick: bool) -> list[str]:
    """The table of ratios against their targets."""
    lines = ["| ratio (CPU time unless said) | measured | target | met |", "|---|---|---|---|"]
    for what, value, op, target, unit in target_rows(res, quick):
        shown = f"{value:.0f}{unit}" if unit else f"{value:.2f}" if value < 10 else f"{value:.0f}"
        if not op:
            lines.append(f"| {what} | {shown} | — | — |")
            continue
        lines.append(f"| {what} | **{shown}** | {op} {target:g}{unit} | {'yes' if value <= target else '**no**'} |")
    return lines


def passes_lines(res: dict) -> list[str]:
    """Tables of the estimator passes and the bands."""
    lines = []
    if "passes" in res:
        t_cumsum = res["passes"]["cumsum"]
        lines += [f"One `numpy.cumsum` over 10⁶ float64: {1e3 * t_cumsum:.2f} ms CPU "
                  f"({1e9 * t_cumsum / N:.2f} ns per sample), median of 31.", "",
                  "| estimator pass over 10⁶ samples | CPU (median) | ÷ cumsum |", "|---|---|---|"]
        lines += [f"| {name} | {1e3 * t:.1f} ms | {t / t_cumsum:.1f} |" for name, t in res["passes"]["rows"]]
        lines += ["", "Target ≤ 10 × cumsum per pass.", ""]
    if "bands" in res:
        b = res["bands"]
        lines += ["| bands from 2000 posterior draws of (m, b) | CPU (median) | ÷ one observer pass |", "|---|---|---|",
                  f"| covariance of the draws through the sensitivities ∂σ̂/∂(m, b) | "
                  f"{1e3 * b['given_sensitivities']:.1f} ms | {b['given_sensitivities'] / b['pass']:.2f} |",
                  f"| the same, counting the two sensitivity passes | {1e3 * b['with_sensitivities']:.1f} ms | "
                  f"{b['with_sensitivities'] / b['pass']:.2f} |",
                  f"| (re-running the estimator per draw, for comparison) | {b['naive']:.1f} s | 2000 |", "", "Target ≤ 3.", ""]
    return lines


def process_lines(res: dict, rounds: int) -> list[str]:
    """The whole-process table."""
    if "process" not in res:
        return []
    names = {"pdf": "`limbstiff analyze FILE --jobs 1` (with its PDF)", "no_pdf": "the same with `--no-pdf`",
             "diagnose": "`limbstiff diagnose FILE --no-pdf --jobs 1`",
             "baseline": "`python benchmarks/ls_baseline.py FILE OUT` (least squares)"}
    lines = [f"Whole processes, median of {rounds} alternating runs each (CPU: user + system of the child; "
             "wall for reference):", "", "| trial | command | CPU (range) | wall | ÷ least squares (CPU) |",
             "|---|---|---|---|---|"]
    for duration, runs in res["process"].items():
        for key, r in runs.items():
            lines.append(f"| {duration:g} s elbow | {names[key]} | {r['cpu']:.2f} s ({min(r['cpus']):.2f}–"
                         f"{max(r['cpus']):.2f}) | {r['wall']:.2f} s | "
                         f"{r['cpu'] / runs['baseline']['cpu']:.2f} |")
    return lines + [""]


def analysis_lines(res: dict, quick: bool) -> list[str]:
    """The in-process analysis, the long trial and the batch."""
    lines = []
    if "analysis" in res or "long" in res:
        lines += ["| CPU, medians of 3 analyses | `analyze` | PDF report | one Kalman pass | analysis ÷ pass |",
                  "|---|---|---|---|---|"]
    if "analysis" in res:
        a = res["analysis"]
        lines += [f"| 60 s elbow, in this process | {a['analysis']:.2f} s | {a['report']:.2f} s | {1e3 * a['kalman']:.1f} ms | "
                  f"{a['ratio']:.0f} |"]
    if "long" in res:
        lg = res["long"]
        lines += [f"| {lg['samples'] / 60000:.0f}-minute ankle, fresh process (report once, the first) | "
                  f"{lg['analysis']:.2f} s | {lg['report']:.2f} s | {1e3 * lg['kalman']:.1f} ms | {lg['ratio']:.0f} |", "",
                  f"Peak memory of the fresh process reading ({lg['file_mb']:.0f} MB CSV, {lg['read']:.1f} s CPU), "
                  f"analysing ({lg['samples']} samples, identification and bands) and reporting the "
                  f"{lg['samples'] / 60000:.0f}-minute trial: **{lg['peak_mb']:.0f} MB** (after imports "
                  f"{lg['imports_mb']:.0f} MB). Target ≤ 1 GB (1000 MB)."]
    if "batch" in res:
        bt = res["batch"]
        lines += ["", f"Batch of {bt['trials']} trials of 60 s ({', '.join(SCENARIOS)} in turn) with a PDF each and "
                  "the overview, run in the order `--jobs` 1, 2, 2, 1, medians: "
                  f"`--jobs 1` {bt['jobs'][1]['wall']:.1f} s wall ({bt['jobs'][1]['cpu']:.1f} s CPU), "
                  f"`--jobs 2` {bt['jobs'][2]['wall']:.1f} s wall ({bt['jobs'][2]['cpu']:.1f} s CPU). One-minute "
                  f"load average before each run (this script's own runs count in it): "
                  f"{', '.join(f'{x:.1f}' for x in bt['loads'])}; other jobs on the 2 cores take from `--jobs 2`."]
    return lines + [""] if lines else []


def length_lines(res: dict) -> list[str]:
    """The table of CPU against trial length."""
    if "length" not in res:
        return []
    ln = res["length"]
    lines = [f"| trial length (ankle, 1 kHz) | `analyze` CPU (identification + bands, no PDF; median of 3 up to "
             f"{ln['up_to']:g} s) | per minute of data |",
             "|---|---|---|"]
    lines += [f"| {d:g} s | {t:.2f} s | {60 * t / d:.2f} s |" for d, t in ln["rows"]]
    return lines + ["", f"Fitted exponent of CPU time against length: **{ln['slope']:.2f}** over "
                        f"10 s–{ln['rows'][-1][0]:g} s ({ln['upper']:.2f} from 100 s up; 1 = linear)."]


def run(parts: list[str], quick: bool, folder: Path) -> dict:
    """Run the chosen parts; their results by part."""
    res = {}
    sig = million() if "passes" in parts or "bands" in parts else None
    if "passes" in parts:
        res["passes"] = passes(sig)
    if "bands" in parts:
        res["bands"] = bands(sig)
    if "analysis" in parts:
        res["analysis"] = analysis(simulate("elbow", seed=3, params={"duration": 60.0}), folder)
    if "length" in parts:
        res["length"] = length_study([10.0, 30.0, 100.0, 300.0, 600.0] + ([] if quick else [1800.0, 3600.0]),
                                     up_to=30.0 if quick else 100.0)
    if "process" in parts:
        res["process"] = process(folder / "process", 3 if quick else 5)
    if "long" in parts:
        res["long"] = long_trial(600.0 if quick else 3600.0, folder)
    if "batch" in parts:
        res["batch"] = batch(folder / "batch", 4 if quick else 8)
    return res


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="length study and long trial up to 10 minutes, 3 process rounds, a batch of 4")
    parser.add_argument("--only", help=f"comma-separated parts among {','.join(PARTS)}; prints, does not write RESULTS.md")
    args = parser.parse_args(argv)
    parts = args.only.split(",") if args.only else list(PARTS)
    unknown = set(parts) - set(PARTS)
    if unknown:
        parser.error(f"unknown parts {sorted(unknown)}; choose among {', '.join(PARTS)}")
    analyze(simulate("ankle", seed=1, params={"duration": 5.0}))          # compile the kernels first
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        res = run(parts, args.quick, Path(tmp))
    load = (load, os.getloadavg()[0])
    rounds = 3 if args.quick else 5
    how = ("How measured: CPU time, not the best of several wall times (a shared 2-core machine): in-process "
           "`time.process_time` (every thread), medians of several calls; whole processes, the child's user + "
           f"system time from `getrusage(RUSAGE_CHILDREN)`, the commands alternating, median of {rounds} each after "
           "unmeasured runs that fill numba's cache. The batch ratio is of wall times (it measures parallelism).")
    lines = ["## Performance (`benchmarks/perf.py`)", "", f"Machine: {machine()}." +
             f" One-minute load average {load[0]:.1f} at the start, {load[1]:.1f} at the end (other jobs share "
             "the machine; CPU time is what they disturb least)." +
             (" A `--quick` run: the long trial is 10 minutes, not one hour." if args.quick else ""), "", how, ""]
    lines += ratio_lines(res, args.quick) + [""] + process_lines(res, rounds) + analysis_lines(res, args.quick)
    lines += passes_lines(res) + length_lines(res)
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.only:
        print("(--only: RESULTS.md not written)")
    else:
        update_section("perf", text)


if __name__ == "__main__":
    main()
