"""Diagnosis of the sim-to-real gap: where the nominal model misses the data, which unmodelled
effect causes it, and how far the gap shrinks once that effect is added, on held-out data.

Modules (one idea each): ``channels`` (the filtered signals of a trial with the nominal model),
``nominal`` (the nominal model, its rows, windows and nuisance, the gap metric), ``where`` (the
residual in time, frequency and regime; whiteness and cross-correlation with bounds),
``kinds`` (how an effect enters the model), ``effects`` (the candidate library), ``residual`` (a
model's residual and where it lies, per trial), ``crossval`` (fitting on training folds, scoring held
out), ``selection`` (greedy selection with a sign-flip test, intervals, ambiguities), ``result``
(``Diagnosis``, ``Candidate``) and ``run`` (:func:`diagnose`, :func:`diagnose_files`).

The package is named for what it measures (the gap between model and recording); the library
call is the plain function :func:`limbstiff.diagnose` (= :func:`limbstiff.gap.diagnose`).
"""

from __future__ import annotations

from .run import diagnose, diagnose_files

__all__ = ["diagnose", "diagnose_files"]
