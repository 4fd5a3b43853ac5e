"""Batches on a ``dask.distributed`` cluster: the executor the runner submits trials to.

Workers read the trial files and write each trial's outputs themselves, with the same atomic
writes as local processes, so the input files and the output folder must be on a file system
the workers share with the client, at the same paths (as on a lab server or an HPC cluster).
Relative paths are resolved against the client's working directory: each task changes to it
first. Returning results to the client to write would ship every report through the scheduler;
a shared file system is what clusters of this kind have, and :func:`check_shared_folder` says
plainly when it is missing. (``limbstiff diagnose`` returns each trial's analysis to the client,
which writes the diagnosis.)

The extra is optional: ``pip install "limbstiff[dask]"``.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from pathlib import Path
from typing import Callable, Iterator

from ..errors import LimbstiffError

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT_S = 15.0
INSTALL_HINT = "pip install 'limbstiff[dask]'"


class ClusterError(LimbstiffError):
    """A scheduler that cannot be used: the extra missing, no answer, or no shared file system."""


@contextlib.contextmanager
def dask_executor(address: str | None, *, timeout: float | None = None) -> Iterator:
    """A :class:`concurrent.futures.Executor` on the dask scheduler at ``address`` (None: no
    executor, the runner's local processes), closed on leaving the block.

    Raises
    ------
    ClusterError
        When ``dask.distributed`` is not installed or the scheduler does not answer.
    """
    if address is None:
        yield None
        return
    try:
        from dask.distributed import Client
    except ImportError:
        raise ClusterError(f"--scheduler {address}: dask.distributed is not installed; {INSTALL_HINT}") from None
    timeout = CONNECT_TIMEOUT_S if timeout is None else timeout
    try:
        client = Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {address}: no dask scheduler answered within {timeout:g} s "
                           f"({type(exc).__name__}); start one (dask scheduler) or check the address") from None
    try:
        # pure=False: every submission is a new task (a re-run must run again, not reuse a result)
        yield client.get_executor(pure=False)
    finally:
        client.close()


def in_folder(folder: str, worker: Callable, job):
    """Run ``worker(job)`` in ``folder`` (the client's working directory), on a worker."""
    if os.getcwd() != folder:
        os.chdir(folder)
    return worker(job)


def _reads(path: str, token: str) -> bool:
    """On a worker: whether the file at ``path`` holds ``token``."""
    try:
        return Path(path).read_text(encoding="utf-8") == token
    except OSError:
        return False


def check_shared_folder(executor, folder: Path) -> None:
    """Check that a worker of ``executor`` sees ``folder`` as the client does.

    Raises
    ------
    ClusterError
        When the file the client wrote there is not what the worker reads.
    """
    token = uuid.uuid4().hex
    probe = Path(folder).resolve() / f".limbstiff-probe-{token}"
    probe.write_text(token, encoding="utf-8")
    try:
        seen = executor.submit(_reads, str(probe), token).result()
    finally:
        probe.unlink(missing_ok=True)
    if not seen:
        raise ClusterError(f"{folder}: the cluster's workers do not see this output folder; give --out a "
                           "folder on a file system the workers share with this machine")
