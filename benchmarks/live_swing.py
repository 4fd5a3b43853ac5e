"""The live ``changing`` check's swing limit, chosen on some trials and verified on others (issue 46).

    python benchmarks/live_swing.py [--train 7100 7200] [--heldout 7300 7400] [--seeds 2]

The live band missed the truth on samples said ``ok`` on the independent simulator where the
stiffness swings back within the live estimate's memory (its ends agree, so the end-to-end rule
said nothing) and in an estimate's first memory (nothing judged yet). Each clean trial of the
independent simulator's suites (``tests/support/independent_trials.py``) and each
``benchmarks/accuracy.py`` scenario of limbstiff's own simulator is replayed through
``LiveSession(fs, Immediately())`` (chunks of 10 samples) once, recording at every check time the
failed checks, ``moved`` (the ends, in half-widths) and ``swing`` (the range within the memory, in
half-widths). The verdict is then re-derived for each candidate rule — the other checks do not
depend on it —: ``ok`` where no other check failed, the estimate has run for its memory (unless
the rule has no ``settling``), ``moved`` ≤ 1 and ``swing`` ≤ the limit. Over the samples after
5 s: the share said ``ok``, the band's coverage on them (95 % Wilson interval, counting samples as
independent, which they are not), the trials with ``ok`` samples whose coverage is below 85 %,
and on the own simulator's constant-stiffness ankle how often the swing alone fires. The limit is
chosen on the ``--train`` suites (the largest candidate holding ≥ 85 % there, of one and two
half-widths: the ends' limit and the band's width) and verified on the ``--heldout`` suites.
Writes the section ``live-swing`` of ``benchmarks/RESULTS.md``; about 6 minutes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from _results import machine, update_section  # noqa: E402
from accuracy import SCENARIOS  # noqa: E402
from checks import wilson  # noqa: E402
from live import independent  # noqa: E402

from limbstiff.live.session import WARMUP_S, Immediately, LiveSession  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

#: Candidate rules: (name, swing limit in half-widths, settling).
RULES = (("ends only, no settling (≈ the rule before issue 46)", np.inf, False), ("ends, settling", np.inf, True),
         ("swing > 1 half-width", 1.0, True), ("swing > 2 half-widths (the band's width)", 2.0, True),
         ("swing > 3 half-widths", 3.0, True))
CHUNK, CONTRACT = 10, 0.85


def replay(trial) -> dict:
    """Per sample after :data:`WARMUP_S` with an estimate: inside the band, the published code, and the
    checks in force (other failures, moved, swing, settling)."""
    n = len(trial.time)
    ts = np.arange(n) / trial.fs
    session = LiveSession(trial.fs, Immediately())
    values, state = np.empty((n, 5)), np.full((n, 4), np.nan)
    for i in range(0, n, CHUNK):
        values[i:i + CHUNK] = session.feed(ts[i:i + CHUNK], trial.angle[i:i + CHUNK], trial.torque[i:i + CHUNK]).values
        c = session.checks
        if c is not None:
            others = bool(set(c.failed) - {"changing", "settling"})
            state[i:i + CHUNK] = (others, c.moved, c.swing, "settling" in c.failed)
    use = (ts >= WARMUP_S) & np.isfinite(values[:, 0]) & (values[:, 4] >= 0)
    truth = trial.stiffness_true[use]
    return {"name": trial.name, "inside": (values[use, 1] <= truth) & (truth <= values[use, 2]),
            "state": state[use]}


def verdict_ok(run: dict, limit: float, settling: bool) -> np.ndarray:
    others, moved, swing, unsettled = run["state"].T
    ok = (others == 0) & ~(moved > 1.0) & ~(swing > limit)
    return ok & (unsettled == 0) if settling else ok & ~np.isnan(others)


def summary(runs: list[dict], limit: float, settling: bool) -> dict:
    oks = [verdict_ok(r, limit, settling) for r in runs]
    k = int(sum(r["inside"][ok].sum() for r, ok in zip(runs, oks)))
    n = int(sum(ok.sum() for ok in oks))
    low = sum(bool(ok.any() and r["inside"][ok].mean() < CONTRACT) for r, ok in zip(runs, oks))
    return {"ok": n / sum(len(ok) for ok in oks), "k": k, "n": n, "low": low, "with_ok": sum(bool(ok.any()) for ok in oks)}


def cell(s: dict) -> str:
    if not s["n"]:
        return f"{100 * s['ok']:.0f} % / – / –"
    lo, hi = wilson(s["k"], s["n"])
    return (f"{100 * s['ok']:.0f} % / {100 * s['k'] / s['n']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}] "
            f"/ {s['low']} of {s['with_ok']}")


def swing_alone(runs: list[dict], limit: float) -> float:
    """Share of the samples of ``runs`` on which the swing alone (the ends within one half-width) fires."""
    state = np.concatenate([r["state"] for r in runs])
    return float(np.mean((state[:, 2] > limit) & ~(state[:, 1] > 1.0)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train", type=int, nargs="+", default=[7100, 7200])
    parser.add_argument("--heldout", type=int, nargs="+", default=[7300, 7400])
    parser.add_argument("--seeds", type=int, default=2, help="seeds per own-simulator scenario (100…)")
    args = parser.parse_args()
    sets = {"train": [replay(t) for t in independent(False, args.train)],
            "held-out": [replay(t) for t in independent(False, args.heldout)],
            "own": [replay(simulate(sc, seed=100 + s, params=p)) for sc, p, _ in SCENARIOS.values()
                    for s in range(args.seeds)]}
    constant = [r for r, (name, _) in zip(sets["own"], [(n, s) for n in SCENARIOS for s in range(args.seeds)])
                if name == "ankle-steady"]
    table = {name: {k: summary(runs, limit, settling) for k, runs in sets.items()} for name, limit, settling in RULES}
    passing = [(limit, name) for name, limit, settling in RULES if np.isfinite(limit) and limit <= 2.0
               and table[name]["train"]["n"] and table[name]["train"]["k"] / table[name]["train"]["n"] >= CONTRACT]
    chosen = max(passing)[1] if passing else None
    lines = ["## The live `changing` check's swing limit (`benchmarks/live_swing.py`, issue 46)", "",
             f"Machine: {machine()}. Clean trials of the independent simulator, train suites "
             f"{', '.join(map(str, args.train))} and held-out suites {', '.join(map(str, args.heldout))} (six each); "
             f"own simulator: the `accuracy.py` scenarios, {args.seeds} seed(s) each. Samples after {WARMUP_S:g} s; "
             "each cell: share said ok / coverage when ok [95 % Wilson, samples counted as independent] / trials "
             f"with ok samples whose coverage is below {100 * CONTRACT:.0f} %.", "",
             "| rule | train | held-out | own | swing alone fires, own constant ankle |", "|---|---|---|---|---|"]
    for name, limit, _ in RULES:
        t = table[name]
        fires = f"{100 * swing_alone(constant, limit):.1f} %" if np.isfinite(limit) else "–"
        lines.append(f"| {name} | {cell(t['train'])} | {cell(t['held-out'])} | {cell(t['own'])} | {fires} |")
    lines += ["", "Chosen on the train suites (the largest limit of one or two half-widths with coverage when ok "
              f"≥ {100 * CONTRACT:.0f} %): " + (chosen or "none") + "; its held-out row verifies it."]
    update_section("live-swing", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
