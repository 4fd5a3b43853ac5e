"""Benchmark data generators written apart from limbstiff's estimation method (issue 46).

numpy + scipy only; every random draw comes from a ``numpy.random.Generator`` the caller seeds.

| module | simulates |
|---|---|
| ``gated_reflex`` | a position-controlled joint (K 30, B 0.8, I 0.012) under a ±0.03 rad PRBS, with a stretch reflex gated at 0.5 rad/s, 40 ms delay, 2nd-order activation (the design of ``benchmarks/reflex_study.py``) |
| ``ensembles`` | small perturbations on large imposed movement cycles; stiffness by phase 15 → 120 N·m/rad with an optional sharp trough; 25–45 ms reflexes; background torque over the cycle (reuses ``benchmarks/ensemble_sim.py``) |
| ``_common`` | :class:`GeneratedTrial` (channels + truth) and the writer of limbstiff's standard CSV |

Command lines: ``python -m benchmarks.generators.gated_reflex OUTDIR --seeds N`` and
``python -m benchmarks.generators.ensembles OUTDIR --seeds N`` (from the repository's root).
See ``README.md`` here for the equations and what is not modelled.
"""
from ._common import GeneratedTrial, bin_means, write_all, write_trial_csv

__all__ = ["GeneratedTrial", "bin_means", "write_all", "write_trial_csv"]
