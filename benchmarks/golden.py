"""A golden snapshot of limbstiff's numbers, to show that a redesign changes no result.

    python benchmarks/golden.py OUT.json            # take a snapshot
    python benchmarks/golden.py OUT.json --compare BEFORE.json

The snapshot holds, with one BLAS thread: every estimator on simulated trials of four set-ups
and on two real ankle trials (``summary.json``'s numbers and a SHA-256 of the course, band and
observable arrays), the identification alone, a two-trial diagnosis with an effect, the
report's words (``StiffnessResult.report()``) and the batch's ``summary.csv``. ``--compare``
prints every value that differs (JSON leaves compared exactly) and exits 1 when any does. Paths
are written relative to the repository (``<repository>``, ``<tmp>``) and the settings' hash,
which covers the protocol's path, is left out, so two clones give the same snapshot.
Run before and after a change that must not change behaviour (issue 33: identical). It snapshots
the limbstiff Python imports (a checkout's through ``PYTHONPATH=<checkout>``) and names it.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import limbstiff  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
REAL = ("z_pf", "z_df3")
SIMULATED = (("elbow", None), ("wrist", None), ("ankle", None), ("paper-exp-spring", None), ("elbow", "reflex"))
ESTIMATORS = ("kalman", "observer-smoothed", "observer")
ANKLE = limbstiff.load_protocol(ROOT / "protocols" / "reklab-ankle.toml")


def digest(array) -> str:
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()[:20]


def jsonable(value):
    return json.loads(json.dumps(value, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v)))


def analysis_entry(result) -> dict:
    return {"summary": jsonable(result.summary()), "report": result.report(),
            "arrays": {name: digest(getattr(result, name))
                       for name in ("stiffness", "stiffness_lo", "stiffness_hi", "observable")}}


def trials() -> dict:
    out = {}
    for scenario, effect in SIMULATED:
        out[f"{scenario}{'+' + effect if effect else ''}"] = simulate(
            scenario, seed=3, effect=effect, params={"duration": 40.0})
    for name in REAL:
        out[name] = limbstiff.read_trial(str(ROOT / "data" / "reklab-ankle" / f"{name}.csv"), ANKLE)
    return out


def snapshot() -> dict:
    from limbstiff.analysis import identify_trial

    snap: dict = {"analysis": {}, "identification": {}}
    loaded = trials()
    for name, trial in loaded.items():
        for estimator in ESTIMATORS:
            result = limbstiff.analyze(trial, ANKLE if name in REAL else None, estimator=estimator, seed=1)
            snap["analysis"][f"{name}/{estimator}"] = analysis_entry(result)
        try:
            ident = identify_trial(trial, ANKLE if name in REAL else None, seed=2)
        except limbstiff.TrialError as exc:
            snap["identification"][name] = str(exc)
            continue
        snap["identification"][name] = jsonable({"inertia": ident.inertia, "damping": ident.damping,
                                                 "covariance": np.asarray(ident.covariance)})
    diagnosis = limbstiff.diagnose([loaded["elbow+reflex"], loaded["wrist"]], seed=4)
    snap["diagnosis"] = jsonable(diagnosis.to_dict())
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for name in ("elbow", "ankle"):
            path = Path(tmp) / f"{name}.csv"
            limbstiff.write_trial(loaded[name], path)
            paths.append(str(path))
        limbstiff.analyze_files(paths, out=Path(tmp) / "out", seed=5, pdf=False)
        table = (Path(tmp) / "out" / "summary.csv").read_text().splitlines()
        snap["batch_summary_csv"] = [line for line in table if "seconds" not in line]
        snap["batch_stiffness_csv"] = {p: digest((Path(tmp) / "out" / p / "stiffness.csv").read_bytes())
                                       for p in ("elbow", "ankle")}
        text = json.dumps(snap).replace(str(ROOT), "<repository>").replace(str(tmp), "<tmp>")
    return json.loads(text, object_hook=lambda d: {k: v for k, v in d.items() if k != "settings_sha256"})


def differences(before, after, path="") -> list[str]:
    if isinstance(before, dict) and isinstance(after, dict):
        out = [f"{path}/{k}: only in one" for k in set(before) ^ set(after)]
        for k in sorted(set(before) & set(after)):
            out += differences(before[k], after[k], f"{path}/{k}")
        return out
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        return [d for i, (b, a) in enumerate(zip(before, after)) for d in differences(b, a, f"{path}[{i}]")]
    return [] if before == after else [f"{path}: {before!r} -> {after!r}"[:400]]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--compare")
    args = parser.parse_args(argv)
    # the limbstiff importable here (an installed copy unless PYTHONPATH names a tree): say which
    print(f"snapshot of {Path(limbstiff.__file__).parent}", file=sys.stderr)
    snap = snapshot()
    Path(args.out).write_text(json.dumps(snap, indent=1, sort_keys=True))
    if not args.compare:
        return 0
    diff = differences(json.loads(Path(args.compare).read_text()), snap)
    for line in diff:
        print(line)
    print(f"{len(diff)} values differ")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
