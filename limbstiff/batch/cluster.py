"""Batches on a ``dask.distributed`` cluster: the executor the runner submits trials to.

Workers read the trial files and write each trial's outputs themselves, with the same atomic
writes as local processes, so the input files and the output folder must be on a file system
the workers share with the client, at the same paths (as on a lab server or an HPC cluster).
Relative paths are opened from the client's working directory (carried by each job) and
recorded as given, so the outputs are those of ``--jobs 1``. Returning results to the client to
write would ship every report through the scheduler; a shared file system is what clusters of
this kind have, and :func:`check_shared_folder` says plainly when it is missing.
(``limbstiff diagnose`` returns each trial's analysis to the client, which writes the diagnosis.)

The extra is optional: ``pip install "limbstiff[dask]"``.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Iterator

from ..errors import LimbstiffError
from ..files.probe import holds, probe_file

#: Seconds to wait for a scheduler, and for a worker to answer the shared-folder probe.
CONNECT_TIMEOUT_S = 15.0
PROBE_TIMEOUT_S = 60.0
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


def _reads(path: str, token: str) -> tuple[bool, str]:
    """On a worker: whether the file at ``path`` holds ``token``, and the worker's limbstiff version."""
    from .. import __version__
    return holds(path, token), __version__


def check_shared_folder(executor, folder: Path, *, timeout: float | None = None) -> None:
    """Check that a worker of ``executor`` answers, runs this limbstiff version, and sees
    ``folder`` as the client does (one worker is asked: a cluster's workers share one set-up).

    Raises
    ------
    ClusterError
        When no worker answers within ``timeout`` s (default :data:`PROBE_TIMEOUT_S`), a worker
        cannot run the probe, runs another version, or does not read what the client wrote.
    """
    from .. import __version__
    timeout = PROBE_TIMEOUT_S if timeout is None else timeout
    with probe_file(folder) as (probe, token):
        try:
            seen, version = executor.submit(_reads, str(probe), token).result(timeout=timeout)
        except TimeoutError:
            raise ClusterError(f"no worker of the cluster answered within {timeout:g} s: start workers "
                               "(dask worker ADDRESS) or check the scheduler") from None
        except Exception as exc:  # noqa: BLE001 - any failure on the worker is the cluster's set-up
            raise ClusterError(f"the cluster's workers cannot run limbstiff ({type(exc).__name__}: "
                               f"{' '.join(str(exc).split())}); install it where they run") from None
    if version != __version__:
        raise ClusterError(f"the cluster's workers run limbstiff {version}, this machine {__version__}: "
                           "install the same version on both")
    if not seen:
        raise ClusterError(f"{folder}: the cluster's workers do not see this output folder; give --out a "
                           "folder on a file system the workers share with this machine")
