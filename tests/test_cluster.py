"""Batches on any executor: a dask LocalCluster gives the same outputs as ``--jobs 1``; a
scheduler that cannot be used, a worker that cannot see the output folder and a lost worker
are one-line failures."""

import json
from concurrent.futures import Executor, Future

import pandas as pd
import pytest
from click.testing import CliRunner

from limbstiff.batch import cluster
from limbstiff.batch.runner import BatchJob, TrialOutcome, run_jobs
from limbstiff.cli import main


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _folder(trial_file, tmp_path, n):
    folder = tmp_path / "trials"
    folder.mkdir()
    for i in range(n):
        trial_file(f"t{i}", folder=folder, seed=i, duration=2.0)
    (folder / "broken.csv").write_text("time_s,angle_rad\n0,1\n")
    return folder


@pytest.mark.slow
def test_dask_local_cluster_equals_jobs_1(trial_file, tmp_path, monkeypatch):
    """Two worker processes of a LocalCluster: every output byte-identical to --jobs 1 (apart
    from the output folder's name), the broken file a failed row, exit status 1 in both."""
    distributed = pytest.importorskip("dask.distributed")
    folder = _folder(trial_file, tmp_path, 2)
    monkeypatch.chdir(tmp_path)                   # relative paths, resolved by the workers
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as local:
        res = run("analyze", folder.name, "--out", "on-dask", "--no-pdf", "--scheduler", local.scheduler_address)
    assert res.exit_code == 1, res.output
    assert "2 of 3 trials done" in res.output and "Traceback" not in res.output
    res = run("analyze", folder.name, "--out", "serial", "--no-pdf", "--jobs", 1)
    assert res.exit_code == 1
    for i in range(2):
        a, b = (tmp_path / out / f"t{i}" for out in ("on-dask", "serial"))
        assert (a / "stiffness.csv").read_bytes() == (b / "stiffness.csv").read_bytes()
        sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
        assert sa.pop("output") == f"on-dask/t{i}" and sb.pop("output") == f"serial/t{i}"
        assert sa == sb
    ta, tb = (pd.read_csv(tmp_path / out / "summary.csv").drop(columns="output") for out in ("on-dask", "serial"))
    pd.testing.assert_frame_equal(ta, tb)
    assert list(ta["status"]) == ["failed", "ok", "ok"]        # input order (broken.csv first), whatever finished first


def test_scheduler_that_does_not_answer(tmp_path, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    res = run("analyze", tmp_path, "--out", tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9")
    assert res.exit_code == 2 and "Traceback" not in res.output
    line = res.output.strip()
    assert "\n" not in line and "no dask scheduler answered" in line and "tcp://127.0.0.1:9" in line
    assert not (tmp_path / "out").exists()                              # nothing written


def test_scheduler_without_the_extra(tmp_path, monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "dask.distributed", None)          # import fails as if not installed
    res = run("identify", tmp_path, "--scheduler", "tcp://127.0.0.1:8786")
    assert res.exit_code == 2
    assert "pip install 'limbstiff[dask]'" in res.output and "Traceback" not in res.output


class _Elsewhere(Executor):
    """An executor whose worker runs on a machine that does not share the client's files."""

    def submit(self, fn, *args, **kwargs):
        fut = Future()
        fut.set_result(fn("/nowhere/" + str(args[0]).lstrip("/"), *args[1:]))
        return fut


def test_output_folder_the_workers_cannot_see(trial_file, tmp_path):
    import limbstiff
    folder = _folder(trial_file, tmp_path, 1)
    with pytest.raises(cluster.ClusterError, match="do not see this output folder"):
        limbstiff.analyze_files([folder], out=tmp_path / "out", pdf=False, executor=_Elsewhere())
    assert not list((tmp_path / "out").iterdir())                       # probe removed, no trial run


class KilledWorker(Exception):
    """Named as dask's: the worker died under the task."""


class _Losing(Executor):
    """Runs tasks at once, but the second task's worker dies and the third cannot be run."""

    def __init__(self):
        self.n = 0

    def submit(self, fn, *args, **kwargs):
        self.n += 1
        fut = Future()
        if self.n == 2:
            fut.set_exception(KilledWorker("out of memory"))
        elif self.n == 3:
            fut.set_exception(RuntimeError("cannot unpickle"))
        else:
            fut.set_result(fn(*args, **kwargs))
        return fut


def _ok(job):
    return TrialOutcome(job.name, str(job.source), "ok")


def test_a_lost_worker_fails_its_trial_only(tmp_path):
    jobs = [BatchJob(source=tmp_path / f"t{i}.csv", name=f"t{i}", out=tmp_path, options={}) for i in range(4)]
    seen = []
    outcomes = run_jobs(jobs, _ok, executor=_Losing(), progress=lambda o, done, total: seen.append(done))
    assert [o.status for o in outcomes] == ["ok", "failed", "failed", "ok"] and seen == [1, 2, 3, 4]
    assert "t1.csv: the worker running it was lost (KilledWorker: out of memory)" in outcomes[1].error
    assert "t2.csv: it could not run on the executor (RuntimeError: cannot unpickle)" in outcomes[2].error


class _Silent(Executor):
    """A cluster with no worker: tasks never finish."""

    def submit(self, fn, *args, **kwargs):
        return Future()


class _Broken(Executor):
    """Workers that cannot import limbstiff."""

    def submit(self, fn, *args, **kwargs):
        fut = Future()
        fut.set_exception(ModuleNotFoundError("No module named 'limbstiff'"))
        return fut


def test_workers_that_do_not_answer_or_cannot_run(tmp_path):
    with pytest.raises(cluster.ClusterError, match="no worker of the cluster answered within 0.1 s"):
        cluster.check_shared_folder(_Silent(), tmp_path, timeout=0.1)
    with pytest.raises(cluster.ClusterError, match="cannot run limbstiff \\(ModuleNotFoundError"):
        cluster.check_shared_folder(_Broken(), tmp_path)
    assert not list(tmp_path.iterdir())                                   # the probe file is gone


def test_jobs_and_scheduler_exclude_each_other(tmp_path):
    res = run("analyze", tmp_path, "--jobs", 2, "--scheduler", "tcp://127.0.0.1:8786")
    assert res.exit_code == 2 and "--jobs and --scheduler exclude each other" in res.output
