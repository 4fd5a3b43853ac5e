"""The cases of issue 47 as a new lab user meets them: each input built as the issue describes it,
in a temporary folder, and the ``limbstiff`` command run on it from a terminal's point of view
(a subprocess). For each case: the command, its exit code and the first line it printed on
stderr and on stdout; for the results-table cases, which trials ``summary.csv`` lists against
the trial folders that are complete.

Sections: advice that fits the file and the protocol (a torque sign under a protocol that already
flips it, and under none; a 4e-6 rad angle under ``angle_rad``; a torque of zeros; a block of 500
empty cells, and the advice followed), folders as labs keep them (a ``subjects.xlsx`` and a
``README.txt`` beside the trials; an ``.ods``), and the results table under concurrency and Ctrl-C
(two ``analyze`` processes into one ``--out``; SIGINT once the first trial of a four-trial batch is done, with
``--jobs 2``). The live terminal needs an LSL stream and is left to ``tests/test_live.py``.

Usage: ``python benchmarks/newcomer.py`` (about 2–3 min); writes ``benchmarks/newcomer.md``.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def my_lab() -> str:
    """The README's own protocol (``protocols/my-lab.toml`` of its "For anything else" section)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("# protocols/my-lab.toml")
    return text[start:text.index("```", start)]


def joint(duration: float = 10.0, fs: float = 500.0, seed: int = 0) -> pd.DataFrame:
    """An elbow-like joint moved by a multisine: f = m·ÿ + b·ẏ + k·y (m 0.06 kg·m², b 0.45
    N·m·s/rad, k 10 → 20 N·m/rad), torque applied to the joint, with a little sensor noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * fs)) / fs
    w = 2 * np.pi * np.linspace(0.7, 6.0, 8)[:, None]
    arg = w * t + rng.uniform(0, 2 * np.pi, (8, 1))
    y, v, a = (0.004 * np.sin(arg).sum(0), 0.004 * (w * np.cos(arg)).sum(0),
               -0.004 * (w ** 2 * np.sin(arg)).sum(0))
    f = 0.06 * a + 0.45 * v + np.linspace(10, 20, t.size) * y + rng.normal(0, 0.005, t.size)
    return pd.DataFrame({"time_s": t, "angle_rad": y, "torque_Nm": f})


def standard(frame: pd.DataFrame, path: Path) -> Path:
    frame.to_csv(path, index=False, float_format="%.9g")
    return path


def advice_inputs(folder: Path) -> list[tuple[str, list[str]]]:
    """The four advice cases of issue 47 (and the empty block's advice followed)."""
    (folder / "my-lab.toml").write_text(my_lab(), encoding="utf-8")
    applied = joint(seed=1)
    export = pd.DataFrame({"Zeit (ms)": applied.time_s * 1e3, "Winkel (°)": np.degrees(applied.angle_rad),
                           "Moment (Nm)": applied.torque_Nm})   # an applied torque, not a reaction one
    export.to_csv(folder / "S01.csv", sep=";", decimal=",", index=False, float_format="%.9g")
    reaction = joint(seed=2)
    reaction["torque_Nm"] *= -1
    tiny = joint(seed=3)
    tiny["angle_rad"] *= 4e-6 / np.ptp(tiny.angle_rad)
    zeros = joint(seed=4)
    zeros["torque_Nm"] = 0.0
    gappy = joint(duration=10.0, fs=1000.0, seed=5)
    text = standard(gappy, folder / "gappy.csv").read_text().splitlines()
    first = 9002 - 1                                  # line 9002 of the file, 1-based
    for i in range(first, first + 500):
        time_s, _, torque = text[i].split(",")
        text[i] = f"{time_s},,{torque}"
    (folder / "gappy.csv").write_text("\n".join(text) + "\n")
    (folder / "cut.csv").write_text("\n".join(text[:first] + text[first + 500:]) + "\n")
    (folder / "bridge.toml").write_text('name = "bridge"\n\n[format]\nmax_gap_s = 0.51\n')
    return [("torque sign, protocol already flips it (README my-lab.toml, applied torque)",
             ["analyze", "S01.csv", "--protocol", "my-lab.toml", "--out", "out-sign-lab"]),
            ("torque sign, no protocol (a reaction torque)",
             ["analyze", standard(reaction, folder / "reaction.csv").name, "--out", "out-sign"]),
            ("angle range 4e-6 rad under angle_rad",
             ["analyze", standard(tiny, folder / "tiny.csv").name, "--out", "out-tiny"]),
            ("torque all zeros", ["analyze", standard(zeros, folder / "zeros.csv").name, "--out", "out-zeros"]),
            ("500 empty cells in angle_rad from line 9002", ["analyze", "gappy.csv", "--out", "out-gappy"]),
            ("the empty block's advice followed (rows deleted, max_gap_s = 0.51)",
             ["analyze", "cut.csv", "--protocol", "bridge.toml", "--out", "out-cut"])]


def folder_inputs(folder: Path) -> list[tuple[str, list[str]]]:
    """A trial folder as labs keep it, and an OpenDocument spreadsheet."""
    lab = folder / "lab"
    lab.mkdir()
    standard(joint(seed=6), lab / "S01.csv")
    pd.DataFrame({"subject": ["S01", "S02"], "name": ["A. B.", "C. D."]}).to_excel(lab / "subjects.xlsx", index=False)
    (lab / "README.txt").write_text("Trials of the elbow study, one file per subject.\n")
    with zipfile.ZipFile(folder / "S02.ods", "w") as ods:        # what LibreOffice writes first
        ods.writestr("mimetype", "application/vnd.oasis.opendocument.spreadsheet")
    return [("subjects.xlsx and README.txt beside the trials", ["analyze", "lab", "--out", "out-lab"]),
            ("an OpenDocument spreadsheet", ["analyze", "S02.ods", "--out", "out-ods"])]


def command() -> list[str]:
    return [sys.executable, "-m", "limbstiff"]


def environment() -> dict:
    return {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}


def first_line(text: str) -> str:
    return next((line.strip() for line in text.splitlines() if line.strip()), "")


def run(args: list[str], folder: Path) -> dict:
    """One command in ``folder``: its exit code and the first line of its stderr and stdout."""
    started = time.perf_counter()
    done = subprocess.run(command() + args, cwd=folder, env=environment(), capture_output=True, text=True,
                          timeout=300)
    return {"command": "limbstiff " + " ".join(args), "exit": done.returncode, "stderr": first_line(done.stderr),
            "stdout": first_line(done.stdout), "seconds": time.perf_counter() - started}


def table_state(out: Path) -> str:
    """Which trials ``summary.csv`` lists, against the trial folders whose outputs are complete."""
    listed = []
    if (out / "summary.csv").exists():
        with open(out / "summary.csv", newline="", encoding="utf-8") as handle:
            listed = sorted(row.get("trial", "") for row in csv.DictReader(line for line in handle
                                                                          if not line.startswith("#")))
    complete = sorted(p.name for p in out.iterdir() if (p / "summary.json").exists()) if out.exists() else []
    table = "no summary.csv" if not (out / "summary.csv").exists() else f"summary.csv lists {listed}"
    return f"{table}; complete trial folders {complete}"


def concurrent(folder: Path) -> list[dict]:
    """Two ``analyze`` processes, different trials, one ``--out``, started side by side."""
    for name in ("A", "B"):
        standard(joint(seed=7 if name == "A" else 8), folder / f"{name}.csv")
    args = [["analyze", f"{name}.csv", "--out", "shared"] for name in ("A", "B")]
    started = time.perf_counter()
    procs = [subprocess.Popen(command() + a, cwd=folder, env=environment(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for a in args]
    rows = []
    for a, proc in zip(args, procs):
        out, err = proc.communicate(timeout=300)
        rows.append({"command": "limbstiff " + " ".join(a) + " (both at once)", "exit": proc.returncode,
                     "stderr": first_line(err), "stdout": first_line(out),
                     "seconds": time.perf_counter() - started})
    rows[-1]["table"] = table_state(folder / "shared")
    return rows


def interrupted(folder: Path) -> dict:
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) during a four-trial batch, as
    soon as its first trial folder is complete (so that the batch is mid-way whatever the machine's speed)."""
    batch = folder / "batch"
    batch.mkdir()
    for k in range(4):
        standard(joint(seed=10 + k), batch / f"T{k + 1}.csv")
    args = ["analyze", "batch", "--jobs", "2", "--out", "out-batch"]
    started = time.perf_counter()
    proc = subprocess.Popen(command() + args, cwd=folder, env=environment(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    while proc.poll() is None and not any((folder / "out-batch").glob("*/summary.json")):
        time.sleep(0.05)
    after_s = time.perf_counter() - started
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=300)
    return {"command": f"limbstiff {' '.join(args)} (Ctrl-C after the first trial, {after_s:.0f} s)",
            "exit": proc.returncode,
            "stderr": first_line(err), "stdout": first_line(out), "seconds": time.perf_counter() - started,
            "table": table_state(folder / "out-batch")}


def markdown(sections: list[tuple[str, list[tuple[str, dict]]]], total: float) -> str:
    lines = ["# Issue 47 as a newcomer meets it", "",
             "Written by `python benchmarks/newcomer.py` (inputs built as issue 47 describes them; each command run "
             f"as a subprocess from the inputs' folder). Total {total:.0f} s.", ""]
    for title, cases in sections:
        lines += [f"## {title}", ""]
        for case, row in cases:
            lines += [f"**{case}**", "", "```text", f"$ {row['command']}", f"exit {row['exit']}",
                      f"stderr: {row['stderr'] or '(nothing)'}", f"stdout: {row['stdout'] or '(nothing)'}"]
            if "table" in row:
                lines.append(f"after: {row['table']}")
            lines += ["```", ""]
    return "\n".join(lines)


def main() -> None:
    start = time.perf_counter()
    sections = []
    with tempfile.TemporaryDirectory(prefix="newcomer-") as tmp:
        folder = Path(tmp)
        for title, build in (("Advice computed from the file and the protocol as given", advice_inputs),
                             ("Folders as labs keep them", folder_inputs)):
            cases = [(case, run(args, folder)) for case, args in build(folder)]
            sections.append((title, cases))
        rows = concurrent(folder)
        sections.append(("The results table under concurrency and Ctrl-C",
                         [("two analyze processes into one --out", r) for r in rows]
                         + [("Ctrl-C during a four-trial batch", interrupted(folder))]))
        text = markdown(sections, time.perf_counter() - start).replace(tmp, "<tmp>")
    (HERE / "newcomer.md").write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
