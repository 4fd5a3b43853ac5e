"""One question, one answer (issue 45): the same trial through ``analyze``, ``analyze --effect reflex``
and ``diagnose`` on the golden trials and the five bundled real ankles.

    python benchmarks/one_answer.py

For each trial (the simulated ones of ``golden.py``: elbow, wrist, ankle, paper-exp-spring and an
elbow with a stretch reflex, 40 s, seed 3; the real ankles with ``protocols/reklab-ankle.toml``):

* the median stiffness ``analyze`` reports against the nominal stiffness ``diagnose`` states for
  the same settings (``after.stiffness_bias.per_trial``, and every candidate's), to the printed
  digits (four significant);
* the reflex's direction and delay in the ``reflex`` check's words, in the shape ``--effect reflex``
  chose, and in the diagnosis's reflex candidate;
* page 1's headline median against the range of the per-cycle medians it draws.

Writes section ``one-answer`` of RESULTS.md.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import re  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import limbstiff  # noqa: E402
from _results import machine, update_section  # noqa: E402
from limbstiff.digest import cycle_course  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
REAL = ("z_df", "z_df2", "z_df3", "z_pf", "z_pf2")
SIMULATED = (("elbow", None), ("wrist", None), ("ankle", None), ("paper-exp-spring", None), ("elbow", "reflex"))


def trials():
    ankle = limbstiff.load_protocol(ROOT / "protocols" / "reklab-ankle.toml")
    for scenario, effect in SIMULATED:
        name = f"{scenario}{'+' + effect if effect else ''}"
        yield name, simulate(scenario, seed=3, effect=effect, params={"duration": 40.0}), None
    for name in REAL:
        yield name, limbstiff.read_trial(str(ROOT / "data" / "reklab-ankle" / f"{name}.csv"), ankle), ankle


def _check_reflex(result) -> str:
    check = next((c for c in result.checks.checks if c.name == "reflex"), None)
    if check is None:
        return "not probed"
    if check.message.startswith("no delayed torque"):
        return "none stands out"
    towards, delay = (re.search(r"towards (positive|negative) angles", check.message),
                      re.search(r"delay (\d+) ms", check.message))
    if towards is None or delay is None:
        return f"unread: {check.message[:60]}"
    return f"{'+' if towards[1] == 'positive' else '−'}1, {delay[1]} ms ({'flagged' if not check.passed else 'within its band'})"


def _shape(params: dict | None) -> str:
    if not params:
        return "—"
    return f"{'+' if params['direction'] > 0 else '−'}1, {1000 * params['delay']:.0f} ms"


def one(name, trial, protocol) -> dict:
    result = limbstiff.analyze(trial, protocol, seed=0)
    median = result.informed_stiffness()[0].median
    diag = limbstiff.diagnose([trial], protocol, seed=0)
    biases = [diag.after.stiffness_bias] + [c.stiffness_bias for c in diag.candidates]
    nominals = {b.per_trial[trial.name].nominal for b in biases if b is not None and trial.name in b.per_trial}
    try:
        with_reflex = limbstiff.analyze(trial, protocol, seed=0, effects=("reflex",))
        effect = _shape(with_reflex.identification.effects[0].shape)
    except limbstiff.LimbstiffError as exc:
        effect = f"failed: {exc}"
    candidate = next((c for c in diag.candidates if c.effect == "reflex"), None)
    course = cycle_course(result)
    drawn = course.stiffness[course.informed]
    return {"trial": name, "median": median, "nominals": sorted(nominals), "check": _check_reflex(result),
            "effect": effect, "diagnose": _shape(None if candidate is None else candidate.params),
            "chosen": "reflex" in diag.diagnosis, "low": float(drawn.min()), "high": float(drawn.max())}


def table(rows: list[dict]) -> str:
    lines = ["| trial | analyze median | diagnose nominal | same to 4 digits | reflex: check | `--effect reflex` | "
             "diagnose (chosen?) | page 1: per-cycle range | headline inside |", "|" + "---|" * 9]
    for r in rows:
        same = all(f"{n:.4g}" == f"{r['median']:.4g}" for n in r["nominals"]) and r["nominals"]
        nominal = ", ".join(f"{n:.4g}" for n in r["nominals"]) or "—"
        inside = r["low"] <= r["median"] <= r["high"]
        lines.append(f"| {r['trial']} | {r['median']:.4g} | {nominal} | {'yes' if same else '**no**'} | {r['check']} | "
                     f"{r['effect']} | {r['diagnose']} ({'yes' if r['chosen'] else 'no'}) | "
                     f"{r['low']:.4g} – {r['high']:.4g} | {'yes' if inside else '**no**'} |")
    return "\n".join(lines)


def main() -> int:
    began = time.perf_counter()
    rows = []
    for name, trial, protocol in trials():
        rows.append(one(name, trial, protocol))
        print(rows[-1], flush=True)
    text = (f"## One question, one answer (`benchmarks/one_answer.py`, issue 45)\n\n"
            f"Machine: {machine()}. {len(rows)} trials in {time.perf_counter() - began:.0f} s. Settings: the "
            f"defaults (Kalman estimator, m and b identified, seed 0); the real ankles with "
            f"`protocols/reklab-ankle.toml`. The reflex as (direction, delay): the `reflex` check's words (its "
            f"probe, left out of the model), the shape `--effect reflex` identified, the diagnosis's reflex "
            f"candidate (whether the diagnosis chose it). A direction of +1 is a stretch towards positive angles.\n\n"
            + table(rows) + "\n")
    update_section("one-answer", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
