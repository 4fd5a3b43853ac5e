"""Diagnosis of the sim-to-real gap: where the nominal model misses the data, which unmodelled
effect causes it, and how far the gap shrinks once that effect is added, on held-out data.

Modules (one idea each): ``channels`` (the filtered signals of a trial), ``nominal`` (the
nominal model, its rows, windows and nuisance, the gap metric), ``where`` (the residual in
time, frequency and regime; whiteness and cross-correlation with bounds), ``effects`` (the
candidate library), ``crossval`` (fitting on training folds, scoring held out), ``select``
(greedy selection with a sign-flip test, intervals, ambiguities), ``result`` (``Diagnosis``,
``Candidate``) and ``run`` (:func:`diagnose`, :func:`diagnose_files`). Importing this package is
light; the functions load their modules when called.

``limbstiff.diagnose`` is both this package and, in the lazy top-level API, the function
:func:`limbstiff.diagnose.run.diagnose`; once the package is imported it shadows the function,
so the package itself is callable and does the same.
"""

from __future__ import annotations

import sys
import types


def diagnose(*args, **kwargs):
    """See :func:`limbstiff.diagnose.run.diagnose`."""
    from .run import diagnose as _diagnose
    return _diagnose(*args, **kwargs)


def diagnose_files(*args, **kwargs):
    """See :func:`limbstiff.diagnose.run.diagnose_files`."""
    from .run import diagnose_files as _diagnose_files
    return _diagnose_files(*args, **kwargs)


class _CallablePackage(types.ModuleType):
    def __call__(self, *args, **kwargs):
        return diagnose(*args, **kwargs)


sys.modules[__name__].__class__ = _CallablePackage

__all__ = ["diagnose", "diagnose_files"]
