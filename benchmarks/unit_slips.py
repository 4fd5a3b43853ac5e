"""Unit slips as a lab makes them: does any come out as a silent wrong answer? (issue 34)

Each trial is written with ``limbstiff.write_trial`` (standard headers ``time_s``, ``angle_rad``,
``torque_Nm``), then its file is rewritten as the slip would leave it — the values of a column
in another unit under the same header, or the right values under another unit's header — and
analysed through ``limbstiff.analyze`` from its path, without a protocol and with the limb's
protocol (``limb`` plus anthropometric priors). Each run is classed:

``caught``    an error, or the verdict ``unreliable`` with a units check, naming the unit;
``flagged``   an error or ``unreliable`` for another reason;
``silent``    ``ok`` or ``caution`` with a median stiffness or inertia more than 20 % off the
              analysis of the correct file (with the same protocol);
``harmless``  ``ok`` or ``caution`` within 20 %.

Target: 0 silent. Usage: ``python benchmarks/unit_slips.py [--duration 15] [--jobs 2]``; writes
section ``unit-slips`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from _results import machine, update_section  # noqa: E402

import limbstiff  # noqa: E402
from limbstiff.errors import LimbstiffError  # noqa: E402
from limbstiff.protocol import load_protocol, protocol_from_dict  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

REAL = HERE.parent / "data" / "reklab-ankle" / "z_df3.csv"
OFF = 0.20                 # a result further than this from the correct file's is wrong
COUNTS_PER_TURN = 4096

#: slip -> (column, how the file is rewritten): "values" multiplies the column's values, "header"
#: renames its unit, "counts" writes encoder counts under the same header
SLIPS = {
    "deg read as rad": ("angle_rad", "values", 180 / math.pi),
    "rad read as deg": ("angle_rad", "header", "angle_deg"),
    "ms read as s": ("time_s", "values", 1000.0),
    "s read as ms": ("time_s", "header", "time_ms"),
    "N·mm read as N·m": ("torque_Nm", "values", 1000.0),
    "N·m read as N·mm": ("torque_Nm", "header", "torque_Nmm"),
    f"counts ({COUNTS_PER_TURN}/turn) read as rad": ("angle_rad", "counts", COUNTS_PER_TURN / (2 * math.pi)),
}
#: scenario -> its limb's protocol (priors as in protocols/*.toml, plus ``limb``)
PROTOCOLS = {
    "elbow": {"name": "elbow", "limb": "elbow", "observer": {"variant": "external"},
              "priors": {"inertia": {"distribution": "lognormal", "median": 0.06, "sigma": 0.4},
                         "damping": {"distribution": "lognormal", "median": 0.4, "sigma": 1.0}}},
    "wrist": {"name": "wrist", "limb": "wrist", "observer": {"variant": "external"}},
    "ankle": {"name": "ankle", "limb": "ankle", "observer": {"variant": "external"},
              "mechanics": {"expected_inertia": [0.010, 0.022]},
              "priors": {"inertia": {"distribution": "lognormal", "median": 0.015, "sigma": 0.5},
                         "damping": {"distribution": "lognormal", "median": 1.0, "sigma": 1.0}}},
}
PROTOCOLS["z_df3 (real ankle)"] = PROTOCOLS["ankle"]


def trials(duration: float) -> dict:
    """The correct trials: simulated elbow, wrist, ankle, and the first ``duration`` s of z_df3."""
    out = {name: simulate(name, seed=1, params={"duration": duration}) for name in ("elbow", "wrist", "ankle")}
    real = limbstiff.read_trial(REAL, load_protocol(HERE.parent / "protocols" / "reklab-ankle.toml"))
    out["z_df3 (real ankle)"] = real.segment(0, int(round(duration * real.fs)) + 1)
    return out


def slip_file(correct: Path, slip: str | None, out: Path) -> Path:
    """Rewrite ``correct`` as the slip would leave it (None: unchanged)."""
    lines = correct.read_text(encoding="utf-8").splitlines()
    if slip is None:
        out.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return out
    column, how, value = SLIPS[slip]
    start = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[start].split(",")
    k = header.index(column)
    if how == "header":
        header[k] = value
        lines[start] = ",".join(header)
    else:
        for i in range(start + 1, len(lines)):
            cells = lines[i].split(",")
            x = float(cells[k]) * value
            cells[k] = str(int(round(x))) if how == "counts" else repr(x)
            lines[i] = ",".join(cells)
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out


def run(path: str, protocol: dict | None) -> dict:
    """Analyse one file: the verdict, the units checks failed, the medians, or the error."""
    proto = None if protocol is None else protocol_from_dict(protocol)
    try:
        result = limbstiff.analyze(limbstiff.read_trial(path, proto), proto)
    except LimbstiffError as exc:
        return {"error": str(exc).split(": ", 1)[-1]}
    units = [c.message for c in result.checks.failed if c.name.startswith("units_")]
    return {"verdict": result.checks.verdict, "units": units, "stiffness": float(np.median(result.stiffness)),
            "inertia": None if result.inertia is None else result.inertia.median,
            "reasons": list(result.checks.reasons)}


def classify(outcome: dict, correct: dict) -> str:
    """``caught``, ``flagged``, ``silent`` or ``harmless`` (see the module's docstring)."""
    if "error" in outcome:
        return "caught" if "unit =" in outcome["error"] else "flagged"
    if outcome["units"]:
        return "caught"
    if outcome["verdict"] == "unreliable":
        return "flagged"
    for key in ("stiffness", "inertia"):
        if correct.get(key) and abs(outcome[key] / correct[key] - 1) > OFF:
            return "silent"
    return "harmless"


def main(duration: float, jobs: int) -> str:
    start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        jobs_in, keys = [], []
        for name, trial in trials(duration).items():
            stem = name.split(" ")[0]
            correct = limbstiff.write_trial(trial, tmp / f"{stem}.csv")
            for slip in (None, *SLIPS):
                path = slip_file(correct, slip, tmp / f"{stem}-{len(keys)}.csv")
                for with_protocol in (False, True):
                    keys.append((name, slip, with_protocol))
                    jobs_in.append((str(path), PROTOCOLS[name] if with_protocol else None))
        with ProcessPoolExecutor(jobs) as pool:
            outcomes = dict(zip(keys, pool.map(run, *zip(*jobs_in))))
    return report(outcomes, duration, time.time() - start)


def report(outcomes: dict, duration: float, seconds: float) -> str:
    names = list(dict.fromkeys(k[0] for k in outcomes))
    classes = {}
    lines = [f"Simulated elbow, wrist and ankle (seed 1) and the real ankle z_df3, first {duration:g} s each; "
             f"each file analysed without a protocol (`none`) and with its limb's protocol (`limb`). "
             f"{machine()}; {seconds:.0f} s.", "",
             "| slip | " + " | ".join(f"{n}: none | {n}: limb" for n in names) + " |",
             "|---|" + "---|" * (2 * len(names))]
    for slip in SLIPS:
        cells = []
        for name in names:
            for with_protocol in (False, True):
                cls = classify(outcomes[(name, slip, with_protocol)], outcomes[(name, None, with_protocol)])
                classes[(name, slip, with_protocol)] = cls
                cells.append(cls)
        lines.append(f"| {slip} | " + " | ".join(cells) + " |")
    counts = {c: sum(v == c for v in classes.values()) for c in ("caught", "flagged", "harmless", "silent")}
    lines += ["", f"Runs: {len(classes)}; caught {counts['caught']}, flagged {counts['flagged']}, "
                  f"harmless {counts['harmless']}, silent {counts['silent']}.", ""]
    clean = [(k, v["error"] if "error" in v else v["verdict"]) for k, v in outcomes.items() if k[1] is None]
    lines.append("Correct files (no false alarm expected): " + "; ".join(
        f"{n} {'limb' if p else 'none'} {v}" for (n, _, p), v in clean) + ".")
    lines += ["", "What each run said (first line of the error, or the units check's reason):", ""]
    for (name, slip, with_protocol), cls in classes.items():
        out = outcomes[(name, slip, with_protocol)]
        said = out.get("error") or (out["units"][0] if out["units"] else
                                    f"verdict {out['verdict']}, stiffness {out['stiffness']:.4g}, inertia "
                                    f"{out['inertia']:.4g}")
        lines.append(f"- {name}, {slip}, {'limb' if with_protocol else 'none'}: **{cls}** — {said}")
    return "## Unit slips (`benchmarks/unit_slips.py`)\n\n" + "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=15.0)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    text = main(args.duration, args.jobs)
    update_section("unit-slips", text)
    print(text)
