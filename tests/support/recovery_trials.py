"""The randomly drawn trials of the identification study (``benchmarks/identify.py``).

Elbows, wrists and ankles in turn, with m, b, noise, encoder and stiffness course drawn at
random; ``tests/test_calibration.py`` simulates the first of them, shortened, for its
simulation-based calibration.
"""

from __future__ import annotations

import numpy as np


def draw_trial(i: int) -> tuple[str, dict, int]:
    """Scenario and parameters of recovery trial ``i``, seeded by ``i``.

    Parameters
    ----------
    i : int
        Index of the trial; the joint cycles through elbow, wrist and ankle.

    Returns
    -------
    joint : str
        Scenario of :func:`limbstiff.simulate.simulate`: ``"elbow"``, ``"wrist"`` or ``"ankle"``.
    params : dict
        Its parameters (inertia, damping, stiffness course, torque noise, encoder; 20 s long).
    seed : int
        Seed of the simulation.
    """
    rng = np.random.default_rng(10_000 + i)
    joint = ("elbow", "wrist", "ankle")[i % 3]
    if joint == "elbow":
        p = {"inertia": rng.uniform(0.04, 0.08), "damping": rng.uniform(0.3, 0.6),
             "stiffness_start": rng.uniform(4, 10), "stiffness_end": rng.uniform(15, 35),
             "torque_noise": rng.uniform(0.005, 0.02), "encoder_counts": float(rng.choice([4096, 8000, 16384]))}
    elif joint == "wrist":
        p = {"inertia": rng.uniform(0.003, 0.006), "damping": rng.uniform(0.03, 0.08),
             "stiffness_start": rng.uniform(0.8, 1.5), "stiffness_end": rng.uniform(2.5, 5.0),
             "torque_noise": rng.uniform(0.001, 0.004), "encoder_counts": float(rng.choice([4096, 8000]))}
    else:
        p = {"inertia": rng.uniform(0.010, 0.020), "damping": rng.uniform(0.6, 1.5),
             "stiffness": rng.uniform(40, 100), "stiffness_variation": rng.uniform(0, 0.3),
             "variation_period": rng.uniform(5, 20), "torque_noise": rng.uniform(0.02, 0.08)}
    p["duration"] = 20.0
    return joint, p, 20_000 + i
