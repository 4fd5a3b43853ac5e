"""Diagnosis of the sim-to-real gap: where the nominal model misses the data, which unmodelled
effect causes it, and how far the gap shrinks once that effect is added, on held-out data.

The nominal model is the analysis's own time-varying Kalman model; candidate effects are extra
terms of its torque equation, their linear coefficients fitted on its innovations, its noise
levels refitted per model; the gap is its held-out one-step-ahead torque prediction error.

Modules (one idea each): ``channels`` (a trial's filtered signals and its analysis), ``nominal``
(the Kalman model at its steps: innovations, marginal likelihood, noise fit, units and blocks;
the gap metric), ``where`` (a residual in time, frequency and regime; whiteness and
cross-correlation with bounds), ``kinds`` (how an effect enters the model), ``candidates`` (the
candidate library, :data:`~limbstiff.effects.registry.CANDIDATES`), ``residual`` (where a model's prediction errors lie, per trial), ``crossval``
(a model's innovations as a regression; fitting on training folds, scoring held out),
``selection`` (greedy selection with a sign-flip test, intervals, ambiguities), ``per_trial``
(each trial's own selection beside the pooled one), ``bias`` (the
stiffness with an effect removed), ``result``
(``Diagnosis``, ``Candidate``), ``run`` (:func:`diagnose`) and ``from_files`` (:func:`diagnose_files`).

The package is named for the command it serves (``limbstiff diagnose``); the library call is the
plain function :func:`limbstiff.diagnose` (= :func:`limbstiff.diagnosis.diagnose`).
"""

from __future__ import annotations

from .from_files import diagnose_files
from .run import diagnose

__all__ = ["diagnose", "diagnose_files"]
