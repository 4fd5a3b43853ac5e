"""The results table is the truth about the folder: runs side by side into one --out, Ctrl-C at
any moment, and files kept beside the trials that are no trials."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from limbstiff.batch.runner import BatchJob, TrialOutcome, run_one
from limbstiff.batch.table import FolderTable, TrialRow
from limbstiff.cli import main
from limbstiff.errors import NotATrial, TrialError
from limbstiff.files.atomic import locked
from limbstiff.files.read import read_trial


def _analyze(*args, **kw):
    cmd = [sys.executable, "-m", "limbstiff", "analyze", *map(str, args)]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, **kw)


def _complete(out):
    """The trial folders whose outputs are all written (summary.json, written last)."""
    return {p.parent.name for p in Path(out).glob("*/summary.json")}


def _ok_rows(out):
    table = pd.read_csv(out / "summary.csv")
    return table, set(table.loc[table["status"] == "ok", "trial"])


def _done(name, **summary):
    return json.dumps({"source": f"{name}.csv", "verdict": "ok", "stiffness": {"median": 1.0}, **summary})


# ---- the table, rebuilt from the folder (fast) -------------------------------------------------

def test_the_table_is_rebuilt_from_the_folder_each_time(tmp_path):
    # run A (a, b) writes its table; run B's trial c completes meanwhile: A's next writing lists it
    out = tmp_path
    (out / "old").mkdir()
    (out / "old" / "summary.json").write_text(_done("old"))
    table = FolderTable(out, "summary.json", ["a", "b"])
    (out / "a").mkdir()
    (out / "a" / "summary.json").write_text(_done("a"))
    finished = {"a": TrialOutcome("a", "a.csv", "ok", "", TrialRow.from_summary(json.loads(_done("a"))))}
    rows, _ = table.write(finished)
    assert [(o.trial, o.resumed) for o in rows] == [("a", False), ("old", True)]
    (out / "c").mkdir()
    (out / "c" / "summary.json").write_text(_done("c"))       # another process's trial
    (out / "b").mkdir()
    (out / "b" / "summary.json").write_text(_done("b"))       # finished during Ctrl-C, no outcome
    rows, _ = table.write(finished)
    assert [(o.trial, o.resumed) for o in rows] == [("a", False), ("b", False), ("c", True), ("old", True)]
    written = pd.read_csv(out / "summary.csv")
    assert list(written["trial"]) == ["a", "b", "c", "old"] and list(written["resumed"]) == [0, 0, 1, 1]
    # a trial folder that is not complete (its marker removed while it is redone) is in no row
    (out / "c" / "summary.json").unlink()
    rows, _ = table.write(finished)
    assert [o.trial for o in rows] == ["a", "b", "old"]


def test_a_trial_of_this_run_kept_from_before_is_resumed_and_a_failed_one_keeps_its_outputs(tmp_path):
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(_done(name))
    table = FolderTable(tmp_path, "summary.json", ["a", "b"])
    rows, _ = table.write({"a": TrialOutcome("a", "a.csv", "failed", "a.csv: broken")})
    assert [(o.trial, o.status, o.resumed) for o in rows] == [("a", "ok", True), ("b", "ok", True)]


def test_the_lock_makes_another_process_wait(tmp_path):
    lock = tmp_path / ".lock"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom limbstiff.files.atomic import locked\n"
         f"with locked({str(lock)!r}):\n    print('held', flush=True)\n    time.sleep(1.5)\n"],
        stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    start = time.monotonic()
    with locked(lock):
        waited = time.monotonic() - start
    holder.wait(timeout=30)
    assert waited > 0.8


# ---- two processes into one --out, Ctrl-C at several moments (end to end) ---------------------

@pytest.mark.slow
def test_two_processes_into_one_out_both_in_the_table_and_the_overview(trial_file, tmp_path):
    out = tmp_path / "out"
    files = [trial_file(f"t{i}", seed=i, duration=4.0) for i in range(2)]
    procs = [_analyze(f, "--out", out, "--jobs", 1) for f in files]
    for proc in procs:
        assert proc.wait(timeout=600) == 0, proc.stderr.read().decode()
    assert _complete(out) == {"t0", "t1"}
    table, ok = _ok_rows(out)
    assert ok == {"t0", "t1"} and len(table) == 2
    if shutil.which("pdftotext"):
        text = subprocess.run(["pdftotext", str(out / "overview.pdf"), "-"], capture_output=True, text=True).stdout
        assert "t0" in text and "t1" in text


@pytest.mark.slow
def test_a_dask_run_beside_a_local_one_into_one_out_both_in_the_table(trial_file, tmp_path):
    """Two trials on a two-worker dask LocalCluster and two more in a local process at the same
    time, into one --out: the table lists all four, and the overview too."""
    distributed = pytest.importorskip("dask.distributed")
    out = tmp_path / "out"
    dask_folder, local_folder = tmp_path / "on-dask", tmp_path / "local"
    for i, folder in enumerate((dask_folder, local_folder, dask_folder, local_folder)):
        folder.mkdir(exist_ok=True)
        trial_file(f"t{i}", folder=folder, seed=i, duration=4.0)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as local:
        procs = [_analyze(dask_folder, "--out", out, "--scheduler", local.scheduler_address),
                 _analyze(local_folder, "--out", out, "--jobs", 1)]
        for proc in procs:
            assert proc.wait(timeout=600) == 0, proc.stderr.read().decode()
    assert _complete(out) == {"t0", "t1", "t2", "t3"}
    table, ok = _ok_rows(out)
    assert ok == {"t0", "t1", "t2", "t3"} and len(table) == 4
    if shutil.which("pdftotext"):
        text = subprocess.run(["pdftotext", str(out / "overview.pdf"), "-"], capture_output=True, text=True).stdout
        assert all(f"t{i}" in text for i in range(4))


@pytest.mark.slow
@pytest.mark.usefixtures("terminal_interrupts")
@pytest.mark.parametrize("after", [0, 1, 2])
def test_ctrl_c_leaves_the_table_listing_exactly_the_complete_trials(trial_file, tmp_path, after):
    folder = tmp_path / "trials"
    folder.mkdir()
    for i in range(4):
        trial_file(f"t{i}", folder=folder, seed=i, duration=4.0)
    out = tmp_path / "out"
    proc = _analyze(folder, "--out", out, "--no-pdf", "--jobs", 2, start_new_session=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if (after and len(_complete(out)) >= after) or (not after and (out / "summary.csv").exists()):
            break
        time.sleep(0.02)
    if not after:
        time.sleep(1.0)                           # the workers are reading and analysing
    os.killpg(proc.pid, signal.SIGINT)            # Ctrl-C on a terminal: the whole process group
    status = proc.wait(timeout=300)
    done = _complete(out)
    assert status == 130 and len(done) >= after, (status, done)
    table, ok = _ok_rows(out)
    assert ok == done                             # every complete trial, and none other
    assert set(table["status"]) <= {"ok"}, table.loc[table["status"] != "ok", ["trial", "error"]].to_dict("records")


@pytest.mark.slow
def test_a_kill_of_the_main_process_lists_the_trials_its_workers_finish_meanwhile(trial_file, tmp_path):
    # SIGTERM to the main process alone: the trials running in the workers finish during the
    # shutdown, complete on disk, and the table written on the way out lists them
    folder = tmp_path / "trials"
    folder.mkdir()
    for i in range(4):
        trial_file(f"t{i}", folder=folder, seed=i, duration=4.0)
    out = tmp_path / "out"
    proc = _analyze(folder, "--out", out, "--no-pdf", "--jobs", 2)
    deadline = time.monotonic() + 300
    while not _complete(out) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    status = proc.wait(timeout=300)
    done = _complete(out)
    # the trial running beside the first finished during the shutdown (and those queued to the
    # workers already, which the executor cannot take back): listed only by the last writing
    assert status == 130 and len(done) >= 2, (status, done)
    assert _ok_rows(out)[1] == done


# ---- folders as labs keep them ------------------------------------------------------------------

def _workbook(path, rows):
    import openpyxl
    book = openpyxl.Workbook()
    for row in rows:
        book.active.append(row)
    book.save(path)
    return path


def test_a_table_without_a_trials_columns_is_no_trial_but_one_with_some_fails_loudly(tmp_path):
    names = _workbook(tmp_path / "subjects.xlsx", [["name", "age", "group"], ["Anna", 34, "A"], ["Ben", 41, "B"]])
    with pytest.raises(NotATrial, match="subjects.xlsx: not a trial: no time, angle or torque column"):
        read_trial(names)
    (tmp_path / "subjects.csv").write_text("name,age\nAnna,34\nBen,41\n")
    with pytest.raises(NotATrial):
        read_trial(tmp_path / "subjects.csv")
    broken = _workbook(tmp_path / "broken.xlsx", [["time_s", "name"], [0.0, "Anna"], [0.01, "Ben"]])
    with pytest.raises(TrialError, match="no angle or position column") as exc:
        read_trial(broken)
    assert not isinstance(exc.value, NotATrial)
    (tmp_path / "mapped.csv").write_text("Zeit;Winkel;Moment\n0;1;2\n0,1;1;2\n")     # a protocol would map it
    with pytest.raises(TrialError, match="a protocol can map them") as exc:
        read_trial(tmp_path / "mapped.csv")
    assert not isinstance(exc.value, NotATrial)


def test_a_file_that_is_no_trial_is_skipped_when_found_in_a_folder_and_failed_when_named(tmp_path):
    names = _workbook(tmp_path / "subjects.xlsx", [["name", "age"], ["Anna", 34]])

    def work(job):
        read_trial(job.source)

    job = BatchJob(source=names, name="subjects", out=tmp_path / "out", options=None)
    named, searched = run_one(job, work), run_one(BatchJob(**{**job.__dict__, "searched": True}), work)
    assert named.status == "failed" and searched.status == "skipped"
    assert searched.error.startswith(f"{names}: not a trial")


def test_an_ods_workbook_is_told_how_to_save_it(tmp_path):
    (tmp_path / "trial.ods").write_bytes(b"PK\x03\x04")
    with pytest.raises(TrialError) as exc:
        read_trial(tmp_path / "trial.ods")
    assert str(exc.value) == (f"{tmp_path / 'trial.ods'}: an OpenDocument spreadsheet (.ods) is not read: "
                              "save it as .xlsx or .csv (LibreOffice: File > Save As)")


def test_a_workbook_found_in_a_trials_folder_is_said_and_skipped(trial_file, tmp_path):
    """An .ods (or .xls) kept in a folder of trials is not passed over in silence: the batch says it
    is not read and how to save it, skips it, and the trial beside it is analysed (exit 0)."""
    folder = tmp_path / "trials"
    folder.mkdir()
    trial_file("t0", folder=folder, duration=3.0)
    (folder / "subjects.ods").write_bytes(b"PK\x03\x04")
    res = CliRunner().invoke(main, ["analyze", str(folder), "--out", str(tmp_path / "out"), "--no-pdf"])
    assert res.exit_code == 0, res.output
    said = [ln for ln in res.output.splitlines() if "subjects.ods" in ln]
    assert len(said) == 1 and "save it as .xlsx or .csv" in said[0] and "skipped" in said[0]
    assert not (tmp_path / "out" / "subjects").exists()


@pytest.mark.slow
def test_a_subjects_list_beside_the_trials_is_skipped_with_one_line(trial_file, tmp_path):
    folder = tmp_path / "trials"
    folder.mkdir()
    trial_file("t0", folder=folder, duration=4.0)
    _workbook(folder / "subjects.xlsx", [["name", "age", "group"], ["Anna", 34, "A"]])
    (folder / "README.txt").write_text("what the trials are")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(folder), "--out", str(out), "--no-pdf", "--jobs", "1"])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "subjects" in ln and ln.startswith("limbstiff:")]
    assert lines == [f"limbstiff: note: {(folder / 'subjects.xlsx').resolve()}: not a trial: no time, angle or "
                     "torque column (expected time_s, angle_deg, torque_Nm or the like; headers found: name, age, "
                     "group); skipped"]
    assert "1 of 1 trials done" in res.output
    assert list(pd.read_csv(out / "summary.csv")["trial"]) == ["t0"] and not (out / "subjects").exists()
