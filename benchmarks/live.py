"""The live (causal) stiffness estimate: accuracy against the offline smoother, latency, LSL loopback (issue 38).

The estimate against the smoother, its latency in-process, and a whole session over the LSL loopback.

    python benchmarks/live.py [--quick] [--only PART[,PART...]] [--seeds 2] [--generators own,independent]
                              [--label NAME]

Parts (``--only`` runs some of them, prints their tables and leaves RESULTS.md alone; so does ``--quick``):

``accuracy``
    Each trial replayed through ``LiveSession(fs, Immediately())`` in chunks of 10 samples, and
    ``limbstiff.analyze`` (the smoother) on the whole trial: the accuracy scenarios of
    ``benchmarks/accuracy.py`` (limbstiff's own simulator, seeds 100 + s) and the six clean trials
    of the independent simulator's suites 7100 and 7200. Over the samples after the first 5 s
    where the live estimate exists: relative errors against the truth, the live band's coverage
    (all samples, and those whose verdict is ok), the share of each verdict code, and the lag —
    the shift of the live course that best matches the smoother's — against the chain's
    ``LiveModel.delay_samples`` (low-pass group delay + the stencil's four samples). Coverage
    among ``ok`` (issue 46), per trial and pooled per simulator: the share of samples said ``ok``,
    the band's coverage on them with a 95 % Wilson interval (counting samples as independent,
    which they are not: hence also per trial), and their median error. ``--generators`` runs one
    simulator's trials only, ``--suites`` other suites of the independent simulator (held-out
    trials); ``--label`` keeps these figures in ``live_ok.json`` under a name
    (``before``: the code before issue 46's changes), and the section shows every label kept.
``latency``
    ``LiveSession.feed`` per sample in steady state, chunks of 1, 10 and 32 samples at 1 kHz on
    ``elbow``: wall time (``time.perf_counter``) and thread CPU time (``time.thread_time``).
``e2e``
    ``limbstiff simulate elbow --stream`` and ``limbstiff stream`` as two processes over the LSL
    loopback (``tests/support/lsl_api.cfg``): the latency and identifications from ``stream.json``
    and the live estimate's error against the recorded true stiffness.

``--quick`` (about 2 minutes, for checking): one seed of 15 s trials, two independent trials cut
to 15 s, one replay per chunk size, one shorter loopback session.
Writes section ``live`` of ``benchmarks/RESULTS.md`` after a full run of every part.
"""

from __future__ import annotations

import argparse
import gc
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))
from _results import machine, update_section  # noqa: E402
from checks import wilson  # noqa: E402
from accuracy import SCENARIOS  # noqa: E402

from limbstiff import analyze  # noqa: E402
from limbstiff.live.checks import VERDICT_NAMES  # noqa: E402
from limbstiff.live.session import WARMUP_S, Immediately, LiveSession  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402
from limbstiff.trial import Trial  # noqa: E402
from tests.support import independent_trials  # noqa: E402

PARTS = ("accuracy", "latency", "e2e")
GENERATORS = ("own", "independent")
#: The independent simulator's suite seeds replayed (``--suites``: others, such as 7300 and 7400, as held-out trials).
SUITES = (7100, 7200)
#: Where ``--label`` keeps the coverage-among-ok figures of each run.
OK_JSON = HERE / "live_ok.json"
SKIP_S = WARMUP_S              # statistics over the samples after the first identification is due
CHUNK = 10                     # samples per chunk in the replays of part 1
MAX_LAG_S, LAG_STEP_S = 3.0, 0.01
CODES = sorted(VERDICT_NAMES)  # -1, 0, 1, 2
LSL_CFG = ROOT / "tests" / "support" / "lsl_api.cfg"
LIMBSTIFF = [sys.executable, "-m", "limbstiff"]


# --- part 1: causal against the smoother --------------------------------------------------------

def replay(trial: Trial, chunk: int) -> tuple[np.ndarray, LiveSession]:
    """The rows a live session publishes for ``trial`` fed in chunks (time stamps arange(n)/fs)."""
    n = len(trial.time)
    ts = np.arange(n) / trial.fs
    session = LiveSession(trial.fs, Immediately())
    values = np.empty((n, 5))
    for i in range(0, n, chunk):
        values[i:i + chunk] = session.feed(ts[i:i + chunk], trial.angle[i:i + chunk], trial.torque[i:i + chunk]).values
    return values, session


def best_lag(live: np.ndarray, smooth: np.ndarray, use: np.ndarray, fs: float) -> tuple[float, float, float]:
    """The shift (s, 0 to :data:`MAX_LAG_S`) minimising the median |live(t + lag) − smooth(t)| / |smooth(t)|
    over the samples ``use`` (those with t + MAX_LAG_S inside the trial, the same for every lag), and
    that median at lag 0 and at the best lag."""
    step, most = max(1, int(round(LAG_STEP_S * fs))), int(round(MAX_LAG_S * fs))
    idx = np.flatnonzero(use)
    idx = idx[idx + most < len(live)]
    lags = np.arange(0, most + 1, step)
    cost = np.array([np.nanmedian(np.abs(live[idx + k] - smooth[idx]) / np.abs(smooth[idx])) for k in lags])
    best = int(np.nanargmin(cost))
    return lags[best] / fs, float(cost[0]), float(cost[best])


def compare(trial: Trial) -> dict:
    """Replay ``trial`` live and analyse it offline; the per-sample comparisons after :data:`SKIP_S`."""
    values, session = replay(trial, CHUNK)
    result = analyze(trial, seed=0)
    live, lo, hi, code = values[:, 0], values[:, 1], values[:, 2], values[:, 4]
    truth, smooth = trial.stiffness_true, result.stiffness
    use = (trial.time - trial.time[0] >= SKIP_S) & np.isfinite(live)
    lag, before, after = best_lag(live, smooth, use, trial.fs)
    model = session.model
    return {"live": np.abs(live[use] - truth[use]) / np.abs(truth[use]),
            "smooth": np.abs(smooth[use] - truth[use]) / np.abs(truth[use]),
            "inside": (lo[use] <= truth[use]) & (truth[use] <= hi[use]),
            "smooth_inside": (result.stiffness_lo[use] <= truth[use]) & (truth[use] <= result.stiffness_hi[use]),
            "code": code[use], "lag": lag, "cost": (before, after),
            "span": np.ptp(np.percentile(truth[use], [5, 95])) / np.median(truth[use]),
            "refits": getattr(session.events, "refits", 0), "delay": model.delay_samples / trial.fs,
            "memory": model.memory_s, "step": model.decimation / trial.fs}


def pooled_row(label: str, source: str, runs: list[dict]) -> str:
    """One table row: the trials' samples pooled, the lags and delays as median [min, max] over trials."""
    def cat(key):
        return np.concatenate([r[key] for r in runs])

    def spread(values, scale, fmt, cap=np.inf):
        v = np.asarray(values) * scale

        def one(x):
            return f"{'≥ ' if x >= cap else ''}{x:{fmt}}"
        inner = f" [{one(min(v))}, {one(max(v))}]" if len(v) > 1 else ""
        return f"{one(np.median(v))}{inner}"

    live, smooth, inside, code = cat("live"), cat("smooth"), cat("inside"), cat("code")
    ok = code == 0
    ok_cov = f"{100 * inside[ok].mean():.0f} %" if ok.any() else "–"
    shares = " / ".join(f"{100 * np.mean(code == c):.0f}" for c in CODES)
    cost0, cost1 = np.median([r["cost"][0] for r in runs]), np.median([r["cost"][1] for r in runs])
    return (f"| {label} | {source} | {len(runs)} | {100 * np.median(live):.1f} % "
            f"| {100 * np.percentile(live, 90):.1f} % "
            f"| {100 * np.median(smooth):.1f} % | {100 * np.percentile(smooth, 90):.1f} % "
            f"| {100 * inside.mean():.0f} % | {ok_cov} | {100 * cat('smooth_inside').mean():.0f} % | {shares} "
            f"| {spread([r['lag'] for r in runs], 1e3, '.0f', MAX_LAG_S * 1e3)} "
            f"| {spread([r['delay'] for r in runs], 1e3, '.0f')} "
            f"| {100 * cost0:.1f} → {100 * cost1:.1f} % | {spread([r['span'] for r in runs], 100, '.0f')} "
            f"| {spread([r['memory'] for r in runs], 1.0, '.2f')} |")


def independent(quick: bool, suites=SUITES) -> list[Trial]:
    """The clean trials of the independent simulator's suites (two cut to 15 s when quick)."""
    specs = [s for seed in suites for s in independent_trials.suite(seed) if s.family == "clean"]
    trials = []
    for spec in specs[:2] if quick else specs:
        data = independent_trials.make_trial(spec)[0]
        if quick:
            data = data[data["time_s"] < 15.0]
        trials.append(Trial(name=f"{spec.name}-{spec.seed}", time=data["time_s"].to_numpy(),
                            angle=data["angle_rad"].to_numpy(), torque=data["torque_Nm"].to_numpy(),
                            stiffness_true=data["stiffness_true_Nm_per_rad"].to_numpy()))
    return trials


ACCURACY_HEADER = [
    "| trial | generator | trials | live median error | live 90th pct | smoother median | smoother 90th pct "
    "| live band coverage | coverage when ok | smoother band coverage | verdict share % (none / ok / caution / "
    "unreliable) | lag, ms | chain delay, ms | live vs smoother at lag 0 → best lag "
    "| true course p5–p95 span, % of median | fading memory, s |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]


def accuracy_part(quick: bool, seeds: int, generators=GENERATORS, suites=SUITES) -> dict:
    """Part 1: rows per accuracy scenario (seeds pooled) and per independent trial, and the
    coverage-among-ok figures (:func:`ok_figures`) per row."""
    rows, own, alone, ok = [], [], [], {}
    for name, (scenario, params, _) in SCENARIOS.items() if "own" in generators else ():
        params = dict(params, **({"duration": 15.0} if quick else {}))
        runs = [compare(simulate(scenario, seed=100 + s, params=params)) for s in range(seeds)]
        own += runs
        rows.append(pooled_row(name, "own", runs))
        ok[name] = ok_figures(runs)
        print(rows[-1], flush=True)
    for trial in independent(quick, suites) if "independent" in generators else ():
        run = compare(trial)
        alone.append(run)
        rows.append(pooled_row(trial.name, "independent", [run]))
        ok[trial.name] = ok_figures([run])
        print(rows[-1], flush=True)
    for label, source, runs in (("**all, own simulator**", "own", own),
                                ("**all, independent simulator**", "independent", alone)):
        if runs:
            rows.append(pooled_row(label, source, runs))
            ok[label] = ok_figures(runs)
    refits = [r["refits"] for r in own + alone]
    return {"rows": rows, "seeds": seeds, "suites": list(suites), "refits": (min(refits), max(refits)), "ok": ok}


def ok_figures(runs: list[dict]) -> dict:
    """The runs' samples pooled: how many, how many said ok, how many of those the band holds the
    truth on, and their median error (None without ok samples)."""
    code, inside, live = (np.concatenate([r[k] for r in runs]) for k in ("code", "inside", "live"))
    ok = code == 0
    return {"samples": int(len(code)), "ok": int(ok.sum()), "inside": int(inside[ok].sum()),
            "median_error": float(np.median(live[ok])) if ok.any() else None}


def _pct_ci(k: int, n: int) -> str:
    if not n:
        return "–"
    lo, hi = wilson(k, n)
    return f"{100 * k / n:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]"


def ok_lines(res: dict, label: str | None) -> list[str]:
    """The coverage-among-ok table: this run's figures per trial and those kept in :data:`OK_JSON`
    under other labels (same trials, same seeds)."""
    kept = json.loads(OK_JSON.read_text(encoding="utf-8")) if OK_JSON.exists() else {}
    if label:
        if tuple(res["suites"]) != SUITES:
            label = f"{label} (suites {' '.join(map(str, res['suites']))})"
        kept[label] = {"seeds": res["seeds"], "suites": res["suites"], "ok": res["ok"]}
        OK_JSON.write_text(json.dumps(kept, indent=1) + "\n", encoding="utf-8")
    shown = {k: v["ok"] for k, v in kept.items()
             if (v["seeds"], v.get("suites", list(SUITES))) == (res["seeds"], res["suites"]) and k != label}
    shown[label or "this run"] = res["ok"]
    lines = ["Coverage among the samples said ok (issue 46): the samples above, those whose verdict code is ok. "
             "The Wilson interval counts the samples as independent, which they are not (the live band's errors "
             f"are correlated over its memory, seconds): the per-trial rows show the spread. Runs kept in "
             f"`benchmarks/{OK_JSON.name}` are shown under their label.", "",
             "| trial | " + " | ".join(f"{k}: ok share / coverage when ok [95 % Wilson] / median error when ok"
                                       for k in shown) + " |", "|---|" + "---|" * len(shown)]
    for trial in res["ok"]:
        cells = []
        for figures in shown.values():
            f = figures.get(trial)
            err = "–" if not f or f["median_error"] is None else f"{100 * f['median_error']:.1f} %"
            cells.append("–" if not f else f"{100 * f['ok'] / max(f['samples'], 1):.0f} % / "
                                           f"{_pct_ci(f['inside'], f['ok'])} / {err}")
        lines.append(f"| {trial} | " + " | ".join(cells) + " |")
    pooled = "**all, independent simulator**"
    other = {k: v["ok"][pooled] for k, v in kept.items() if v.get("suites", list(SUITES)) != res["suites"]
             and pooled in v["ok"]}
    if other:
        lines += ["", "Other suites of the independent simulator (`--suites`, kept in the JSON), their six clean trials "
                  "pooled: ok share / coverage when ok [95 % Wilson] / median error when ok:", ""]
        for k, f in other.items():
            err = "–" if f["median_error"] is None else f"{100 * f['median_error']:.1f} %"
            lines.append(f"- {k}: {100 * f['ok'] / max(f['samples'], 1):.0f} % / {_pct_ci(f['inside'], f['ok'])} / {err}")
    return lines


# --- part 2: latency in-process -----------------------------------------------------------------

def model_updates(session: LiveSession) -> int:
    """Identifications and noise refits taken in so far (or failed)."""
    ev = session.events
    return len(ev.identifications) + getattr(ev, "refits", 0) + len(getattr(ev, "failed_refits", ()))


def time_feeds(trial: Trial, chunk: int) -> tuple[np.ndarray, int]:
    """Wall and thread-CPU seconds per sample of each steady-state chunk and whether it ran the checks
    (every 0.25 s), shape (chunks, 3): after the first identification was taken, leaving out every chunk
    that ran an identification or a noise refit (``Immediately`` runs them inside ``feed``: the chunk
    whose record reached the due length) or took one in; and how many steady-state chunks were left
    out. Garbage is collected before the replay, not during it."""
    n = len(trial.time)
    ts = np.arange(n) / trial.fs
    session = LiveSession(trial.fs, Immediately())
    kept, excluded = [], 0
    gc.collect()
    for i in range(0, n - chunk + 1, chunk):
        pending, taken, checks = session.pending, model_updates(session), session.events.checks
        w0, c0 = time.perf_counter(), time.thread_time()
        session.feed(ts[i:i + chunk], trial.angle[i:i + chunk], trial.torque[i:i + chunk])
        wall, cpu = time.perf_counter() - w0, time.thread_time() - c0
        identified = session.pending is not pending or model_updates(session) != taken
        if session.model is not None and taken and not identified:
            kept.append((wall / chunk, cpu / chunk, session.events.checks is not checks))
        excluded += bool(taken and identified)
    return np.array(kept), excluded


def latency_part(quick: bool) -> dict:
    """Part 2: per-sample times of ``feed`` for chunks of 1, 10 and 32 samples (replays pooled)."""
    repeats = 1 if quick else 3
    trials = [simulate("elbow", seed=200 + r, params={"duration": 15.0} if quick else {}) for r in range(repeats)]
    rows = []
    for chunk in (1, 10, 32):
        timed = [time_feeds(trial, chunk) for trial in trials]
        both = np.concatenate([t[0] for t in timed])
        times, checked = both[:, :2] * 1e6, both[:, 2] > 0
        rows.append((chunk, len(times), *np.median(times, axis=0), *np.percentile(times, 99.9, axis=0),
                     *times.max(axis=0), np.median(times[checked, 1]) * chunk / 1e3, checked.mean(),
                     sum(t[1] for t in timed)))
        print(rows[-1], flush=True)
    return {"rows": rows, "repeats": repeats, "seconds": trials[0].duration}


def latency_lines(res: dict) -> list[str]:
    lines = [f"Per sample, µs: `LiveSession.feed` chunk time ÷ chunk size, elbow at 1 kHz, {res['repeats']} "
             f"replay(s) of {res['seconds']:.0f} s pooled (seeds 200…). Steady state only: chunks after the first "
             "identification was taken in, **excluding every chunk during which an identification or a noise refit "
             "ran** (`Immediately` runs them synchronously inside `feed`) or was taken in (their number: "
             "\"left out\"). Targets: median ≤ 50 µs, "
             "99.9th percentile ≤ 1000 µs.", "",
             "| chunk | chunks | left out | median wall | median thread CPU | 99.9th pct wall | 99.9th pct thread CPU "
             "| max wall | max thread CPU | targets met: wall / CPU | chunks running the checks: share, median "
             "thread CPU per chunk |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for chunk, count, mw, mc, pw, pc, xw, xc, check_ms, share, left in res["rows"]:
        met = " / ".join("yes" if m <= 50 and p <= 1000 else "**no**" for m, p in ((mw, pw), (mc, pc)))
        lines.append(f"| {chunk} | {count} | {left} | {mw:.1f} | {mc:.1f} | {pw:.1f} | {pc:.1f} | {xw:.0f} | {xc:.0f} "
                     f"| {met} | {100 * share:.1f} %, {check_ms:.2f} ms |")
    return lines


# --- part 3: a whole session over the LSL loopback ----------------------------------------------

def session(folder: Path, name: str, duration: float) -> dict:
    """One ``limbstiff simulate elbow --stream`` publisher and one ``limbstiff stream`` consumer on the
    loopback; the consumer's stream.json, its live estimate's error and the processes' wall times."""
    env = {**os.environ, "LSLAPICFG": str(LSL_CFG)}
    pub_cmd = [*LIMBSTIFF, "simulate", "elbow", "--stream", "--stream-name", name, "--duration", f"{duration:g}",
               "--wait-consumer", "20"]
    sub_cmd = [*LIMBSTIFF, "stream", "--name", name, "--duration", f"{duration - 2:g}", "--out", str(folder),
               "--trial", "e2e", "--no-pdf", "--quiet", "--outlet", f"{name}-out"]
    start = time.perf_counter()
    pub = subprocess.Popen(pub_cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    sub = subprocess.Popen(sub_cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    sub_err = sub.communicate(timeout=duration + 180)[1]
    pub_err = pub.communicate(timeout=60)[1]
    wall = time.perf_counter() - start
    if sub.returncode or pub.returncode:
        raise RuntimeError(f"loopback session failed ({pub.returncode}, {sub.returncode}):\n{pub_err[-2000:]}\n"
                           f"{sub_err[-2000:]}")
    summary = json.loads((folder / "e2e" / "stream.json").read_text(encoding="utf-8"))
    return {"summary": summary, "error": live_error(folder), "wall": wall}


def read_table(path: Path) -> pd.DataFrame:
    """A CSV written by limbstiff: ``#`` metadata lines, headers, and an optional unit row."""
    table = pd.read_csv(path, comment="#")
    if not all(pd.api.types.is_numeric_dtype(t) for t in table.dtypes):    # the unit row made the columns text
        table = table.iloc[1:].apply(pd.to_numeric)
    return table.reset_index(drop=True)


def live_error(folder: Path) -> dict:
    """The live estimate (live.csv) against the recording's true stiffness, joined on the LSL time stamps,
    over the samples after :data:`SKIP_S` where the live estimate exists."""
    live, rec = read_table(folder / "e2e" / "live.csv"), read_table(folder / "e2e.csv")
    # one recording row per live row when nothing was left out (no break, no sample that is not a
    # number): joined in order. The recording's time is on the nominal grid and the live table's the
    # raw stamps, which LSL's clock correction moves by more than a join on time could allow.
    if len(rec) != len(live):
        raise RuntimeError(f"the recording has {len(rec)} rows and live.csv {len(live)}: not joined in order")
    pos = np.arange(len(live))
    matched = np.ones(len(live), dtype=bool)
    truth = rec["stiffness_true_Nm_per_rad"].to_numpy()[pos]
    est = live["stiffness"].to_numpy()
    use = matched & np.isfinite(est) & (live["time_s"].to_numpy() >= SKIP_S)
    first = float(live["time_s"].to_numpy()[np.isfinite(est)][0]) if np.isfinite(est).any() else np.nan
    if not use.any():
        return {"replayed": np.nan, "median": np.nan, "p90": np.nan, "coverage": np.nan, "ok_share": np.nan,
                "ok_coverage": np.nan, "samples": 0, "first": first}
    rel = np.abs(est[use] - truth[use]) / np.abs(truth[use])
    inside = (live["stiffness_lo"].to_numpy()[use] <= truth[use]) & (truth[use] <= live["stiffness_hi"].to_numpy()[use])
    ok = live["verdict"].to_numpy()[use] == 0
    return {"replayed": replayed_error(rec), "median": float(np.median(rel)), "p90": float(np.percentile(rel, 90)),
            "coverage": float(inside.mean()),
            "ok_share": float(ok.mean()), "ok_coverage": float(inside[ok].mean()) if ok.any() else np.nan,
            "samples": int(use.sum()), "first": first}


def replayed_error(rec: pd.DataFrame) -> float:
    """Median live error after :data:`SKIP_S` of the same recording replayed in-process (``Immediately``,
    chunks of :data:`CHUNK`): the session without the worker's delay."""
    trial = Trial(name="e2e", time=np.arange(len(rec)) / 1000.0, angle=rec["angle_rad"].to_numpy(),
                  torque=rec["torque_Nm"].to_numpy(), stiffness_true=rec["stiffness_true_Nm_per_rad"].to_numpy())
    live = replay(trial, CHUNK)[0][:, 0]
    use = (trial.time >= SKIP_S) & np.isfinite(live)
    return float(np.median(np.abs(live[use] - trial.stiffness_true[use]) / trial.stiffness_true[use]))


def e2e_part(quick: bool) -> dict:
    """Part 3: loopback sessions (2, or 1 of 12 s when quick), each under a stream name of its own."""
    runs = []
    duration = 12.0 if quick else 30.0
    for k in range(1 if quick else 2):
        name = f"limbstiff-bench-{os.getpid()}-{k}"
        with tempfile.TemporaryDirectory() as tmp:
            runs.append(session(Path(tmp), name, duration))
        print(json.dumps(runs[-1]["summary"]["latency"]), runs[-1]["error"], flush=True)
    return {"runs": runs, "duration": duration}


def e2e_lines(res: dict) -> list[str]:
    d = res["duration"]
    lines = [f"`limbstiff simulate elbow --stream --duration {d:g} --wait-consumer 20` and `limbstiff stream "
             f"--duration {d - 2:g} --no-pdf --quiet` (its outlet under a name of its own), two processes on the "
             "loopback (`LSLAPICFG=tests/support/lsl_api.cfg`); the identification in `limbstiff stream`'s worker "
             "process. Processing: µs per sample of the chunk's `feed` + outlet push; end-to-end: the time the "
             "chunk was pulled plus its processing, minus its last sample's LSL time stamp (from `stream.json`). "
             "Live error: against the recording's `stiffness_true_Nm_per_rad`, after 5 s; the same recording replayed "
             "in-process with `Immediately` (identifications at once, chunks of 10) for comparison.", "",
             "| run | chunks | processing µs/sample: median / p99 / p99.9 / max | the same in the loop's CPU time "
             "| end-to-end ms: median / p99 / "
             "p99.9 / max | identifications at (s of record); noise refits | first live estimate at (s) "
             "| samples / dropped / breaks "
             "| live median error | live 90th pct | live band coverage | ok share / coverage when ok "
             "| same recording replayed in-process: median error "
             "| wall s |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, run in enumerate(res["runs"], 1):
        s, e = run["summary"], run["error"]
        p, q = s["latency"]["processing_us_per_sample"], s["latency"]["end_to_end_ms"]
        c = s["latency"].get("processing_cpu_us_per_sample")
        cpu = "–" if not c else f"{c['median']:.1f} / {c['p99']:.1f} / {c['p99_9']:.0f} / {c['max']:.0f}"
        ids = ", ".join(f"{i['at_s']:g}" + (" (error)" if "error" in i else "") for i in s["identifications"])
        ids += f"; {s.get('noise_refits', 0)} noise refits ({len(s.get('failed_noise_refits', []))} failed)"
        lines.append(f"| {k} | {p['chunks']} | {p['median']:.1f} / {p['p99']:.1f} / {p['p99_9']:.0f} / {p['max']:.0f} "
                     f"| {cpu} "
                     f"| {q['median']:.2f} / {q['p99']:.2f} / {q['p99_9']:.1f} / {q['max']:.1f} | {ids} "
                     f"| {e['first']:.2f} "
                     f"| {s['samples']} / {s['dropped_samples']} / {len(s['breaks'])} | {100 * e['median']:.1f} % "
                     f"| {100 * e['p90']:.1f} % | {100 * e['coverage']:.0f} % "
                     f"| {100 * e['ok_share']:.0f} % / {100 * e['ok_coverage']:.0f} % | {100 * e['replayed']:.1f} % "
                     f"| {run['wall']:.0f} |")
    return lines


# --- the section --------------------------------------------------------------------------------

def accuracy_lines(res: dict, quick: bool, label: str | None = None) -> list[str]:
    seeds = res["seeds"]
    return [f"Own simulator: the `benchmarks/accuracy.py` scenarios, {seeds} seed(s) each (100…{99 + seeds}), pooled"
            f"{', 15 s trials' if quick else ''}; independent simulator: the six `clean` trials of "
            f"{' and '.join(f'`suite({x})`' for x in res['suites'])}{' (two, cut to 15 s)' if quick else ''}. Live: `LiveSession(fs, Immediately())` fed "
            f"chunks of {CHUNK} samples (identifications at 5, 10, 20 s of record, noise refits between them: "
            f"{res['refits'][0]}–{res['refits'][1]} per trial); smoother: "
            "`analyze(trial, seed=0)`. "
            f"Statistics over the samples after the first {SKIP_S:g} s where the live estimate exists; errors "
            "|σ̂ − σ|/σ against the truth; coverage of the nominal 90 % bands. "
            "Lag: the shift of the live course, "
            f"0–{MAX_LAG_S:g} s in steps of {LAG_STEP_S * 1e3:g} ms (one sample at 66.7 Hz), minimising the median "
            "|live(t + lag) − smoother(t)| / |smoother(t)|; that median at lag 0 and at the best lag in the "
            "next-to-last column. Chain delay: the final `LiveModel.delay_samples` / fs (the causal low-pass's group "
            "delay at 0 Hz + the stencil's 4 samples). Lags and delays: median [min, max] over trials; fading memory: "
            "`LiveModel.memory_s` (2 motion periods). Where the true course hardly varies (small span) the lag is not "
            "defined by the data (the lag-0 and best-lag medians are then nearly equal); ≥ 3000: the search's end.",
            "", *ACCURACY_HEADER, *res["rows"], "", *ok_lines(res, label)]


def version() -> str:
    """The commit the run was made on, and the library's files changed in the working tree."""
    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()

    changed = git("status", "--porcelain", "--", "limbstiff").splitlines()
    diff = subprocess.run(["git", "diff", "--", "limbstiff"], cwd=ROOT, capture_output=True).stdout
    return f"commit {git('rev-parse', '--short', 'HEAD')}" + (
        f" with uncommitted changes to {', '.join(c.split()[-1] for c in changed)} (diff sha1 "
        f"{hashlib.sha1(diff).hexdigest()[:8]})" if changed else "")


def section(res: dict, quick: bool, load: tuple[float, float], code: tuple[str, str], label: str | None = None) -> str:
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = ["## Live estimate (`benchmarks/live.py`, issue 38)", "",
             f"Machine: {machine()}; run {stamp} on {code[0]}"
             + ("" if code[0] == code[1] else f" (at the end: {code[1]}; the working tree changed during the run)")
             + f"; one-minute load average {load[0]:.1f} at the start, "
             f"{load[1]:.1f} "
             "at the end (a shared machine)." + (" A `--quick` run." if quick else ""), ""]
    if "accuracy" in res:
        lines += ["### Causal live estimate against the offline smoother", "",
                  *accuracy_lines(res["accuracy"], quick, label), ""]
    if "latency" in res:
        lines += ["### Latency in-process", "", *latency_lines(res["latency"]), ""]
    if "e2e" in res:
        lines += ["### End to end over the LSL loopback (limbstiff's own simulator, elbow, seed 0)", "",
                  *e2e_lines(res["e2e"]), ""]
    return "\n".join(lines).rstrip() + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="about 2 minutes; prints, does not write RESULTS.md")
    parser.add_argument("--only", help=f"comma-separated parts among {','.join(PARTS)}; "
                                       "prints, does not write RESULTS.md")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per accuracy scenario (full mode)")
    parser.add_argument("--generators", default=",".join(GENERATORS),
                        help="the accuracy part's trials: own, independent or both (comma-separated); "
                             "one alone prints, does not write RESULTS.md")
    parser.add_argument("--suites", type=int, nargs="+", default=list(SUITES),
                        help="the independent simulator's suite seeds (others than 7100 7200: prints, does not "
                             "write RESULTS.md)")
    parser.add_argument("--label", help=f"keep the coverage-among-ok figures in benchmarks/{OK_JSON.name} "
                                        "under this name (e.g. before, after)")
    args = parser.parse_args(argv)
    generators = args.generators.split(",")
    if set(generators) - set(GENERATORS):
        parser.error(f"unknown generators {sorted(set(generators) - set(GENERATORS))}; choose among own, independent")
    parts = args.only.split(",") if args.only else list(PARTS)
    unknown = set(parts) - set(PARTS)
    if unknown:
        parser.error(f"unknown parts {sorted(unknown)}; choose among {', '.join(PARTS)}")
    load, res, code = os.getloadavg()[0], {}, version()
    if "accuracy" in parts:
        res["accuracy"] = accuracy_part(args.quick, 1 if args.quick else args.seeds, generators, args.suites)
    if "latency" in parts:
        res["latency"] = latency_part(args.quick)
    if "e2e" in parts:
        res["e2e"] = e2e_part(args.quick)
    text = section(res, args.quick, (load, os.getloadavg()[0]), (code, version()), args.label)
    print(text)
    partial = args.only or args.quick or set(generators) != set(GENERATORS) or tuple(args.suites) != SUITES
    if partial:
        print("(--only, --quick or one generator: RESULTS.md not written)")
    else:
        update_section("live", text)


if __name__ == "__main__":
    main()
