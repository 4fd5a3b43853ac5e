"""One BLAS thread inside the numerical work, so that results are the same to the bit everywhere.

A threaded BLAS splits a sum differently with the number of threads, so the same trial gave inertia
0.0249857 with one OpenBLAS thread and 0.0249854 with two, and a dask worker could disagree with
``--jobs 1`` in the fifth digit. The model's products are tiny (a few thousand steps by a few
channels), so threads bought no speed either: ``initial_slopes`` took 16 ms threaded and 0.03 ms on
one thread, and threaded BLAS cost 25–30 % more CPU (issue 33). Parallelism comes from processes
(the batch runner, dask workers), one trial each.

:func:`one_blas_thread` limits every BLAS library loaded in the process (numpy's and scipy's
OpenBLAS, MKL…) through ``threadpoolctl`` for the duration of a call and restores the caller's
setting afterwards, so a notebook keeps its own. Nested and concurrent calls share one limit: the
first to enter sets it, the last to leave restores it.
"""

from __future__ import annotations

import functools
import threading
from typing import Callable, TypeVar

F = TypeVar("F", bound=Callable)

_lock = threading.Lock()
_active = 0
_limiter = None


def _enter() -> None:
    global _active, _limiter
    with _lock:
        if _active == 0:
            from threadpoolctl import threadpool_limits
            _limiter = threadpool_limits(limits=1, user_api="blas")
        _active += 1


def _leave() -> None:
    global _active, _limiter
    with _lock:
        _active -= 1
        if _active == 0:
            _limiter.restore_original_limits()
            _limiter = None


def one_blas_thread(func: F) -> F:
    """Decorate ``func`` so that it runs with BLAS limited to one thread (module docstring)."""
    @functools.wraps(func)
    def limited(*args, **kwargs):
        _enter()
        try:
            return func(*args, **kwargs)
        finally:
            _leave()
    return limited
