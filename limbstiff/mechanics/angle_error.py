"""What the angle's measurement error does to inertia and damping, measured by simulation.

m and b are fitted by regressing the torque on ÿ and ẏ, which are derived from the recorded
angle. Its quantisation is an error in these variables: they bias the fit (towards
zero, the regression dilution) and add a spread that the likelihood, whose noise is all on the
torque, does not contain. The quantisation error of a slowly moving angle is not white — a
staircase whose frequency is the speed over the step, in the filter's band near every reversal —
so its effect is measured rather than modelled: the smooth angle is quantised again (the grid at a
random offset), filtered by the same chain, and m and b
fitted again at the same noise levels. The mean change estimates the bias, the spread the
variance it adds (a parametric bootstrap of the measurement error; the idea of SIMEX, Cook &
Stefanski 1994, J. Am. Stat. Assoc. 89:1314).

Measured on 60 of the simulated trials of ``benchmarks/identify.py``: without it m was
identified about one posterior standard deviation low on the encoders (90 % intervals held it in
70 % of the elbows and wrists; with it and the corrected covariance, 95 % and 92 % of 200 each,
section ``identify`` of ``benchmarks/RESULTS.md``). The sandwich is built from the torque
residual, which holds the recording's own quantisation, so the same simulated errors also give
that part of it (``in_residual``), taken off the sandwich before the spread is added: the
sandwich's mean increase when the error is added, measured by the same estimator (m and b
refitted, the residual and the regressors holding the error, as the recording's own error enters
it). Taken instead as the sandwich of the error's torque −m·ÿ − b·ẏ alone, it was 1.6–3.1× the
recording's part of m's sandwich (the recording's sandwich less that of its exact-angle twin;
section ``identify_intervals`` of ``benchmarks/RESULTS.md`` at 8d27b00, medians per encoder, elbows and
wrists): the torque noise's part was taken off with it, and b's intervals held the truth in 86 %
of the elbows and wrists of ``benchmarks/identify.py``. Measured as now it is 1.0–2.3× that part
(0.9–2.2× for b). White angle noise is not simulated (see :func:`angle_error_effect`). Pure
numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..filtered import Filtered

#: Simulated recordings of the angle's error per trial: the shift's own standard error is then
#: a quarter of the spread it estimates, and its variance is carried too (×(1 + 1/draws)).
ERROR_DRAWS = 16


@dataclass(frozen=True)
class AngleErrorEffect:
    """The change of (m, b) that the angle's measurement error causes, and its spread.

    Parameters
    ----------
    kind : {"quantisation", "none"}
        The error simulated: the recording's quantiser (step ``size``), or none.
    size : float, rad (m)
    shift : ndarray, shape (2,)
        Mean change of (m, b) with the error against without it: subtracted from the fit.
    covariance : ndarray, shape (2, 2)
        The spread of (m, b) over the simulated errors (with the shift's own uncertainty): added
        to the posterior's.
    draws : int
    in_residual : ndarray, shape (2, 2)
        The part of the sandwich covariance that the simulated errors make (its mean increase when
        one is added): the sandwich sees the recording's own error that way, so this is taken off
        it before ``covariance`` is added (else counted twice).
    """

    kind: str
    size: float
    shift: np.ndarray
    covariance: np.ndarray
    draws: int
    in_residual: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))

    def to_dict(self) -> dict:
        return {"kind": self.kind, "size": self.size, "inertia_shift": float(self.shift[0]),
                "damping_shift": float(self.shift[1]), "inertia_sd": float(np.sqrt(self.covariance[0, 0])),
                "damping_sd": float(np.sqrt(self.covariance[1, 1])), "draws": self.draws,
                "inertia_sd_in_residual": float(np.sqrt(max(self.in_residual[0, 0], 0.0))),
                "damping_sd_in_residual": float(np.sqrt(max(self.in_residual[1, 1], 0.0)))}


NO_EFFECT = AngleErrorEffect("none", 0.0, np.zeros(2), np.zeros((2, 2)), 0)


def angle_error_effect(filtered: Filtered, fit: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray | None]], *,
                       rng: np.random.Generator, draws: int = ERROR_DRAWS) -> AngleErrorEffect:
    """The effect of the angle's measurement error on (m, b).

    Parameters
    ----------
    filtered : Filtered
        The trial's signals: the smooth angle, its chain, the quantisation step found.
    fit : callable
        From the angle's channels, an array (3, n) of y, ẏ, ÿ (the torque and the noise levels
        held fixed): (m, b) fitted, shape (2,), and the sandwich covariance (2, 2) of that fit, or
        None (``in_residual`` is then 0).
    rng : numpy.random.Generator
        The grid's offsets.
    draws : int

    Returns
    -------
    AngleErrorEffect
        :data:`NO_EFFECT` when the angle shows no quantisation.
    """
    smooth = filtered.angle
    step = float(filtered.bandwidth.quantisation_step)
    if not step > 0:
        # white noise is left out: on a noise-free synthetic trial its simulation moved m by 100 %
        # (the noise-free refit is ill-conditioned), and on continuous angles the effect measured
        # was nil (the ankles of benchmarks/identify.py)
        return NO_EFFECT
    base, base_sandwich = fit(filtered.chain.apply(smooth, 2))
    out = np.empty((draws, 2))
    seen = np.zeros((2, 2))
    for j in range(draws):
        offset = rng.uniform(0.0, step)
        out[j], sandwich = fit(filtered.chain.apply(step * np.round((smooth - offset) / step) + offset, 2))
        if base_sandwich is not None:
            seen += (sandwich - base_sandwich) / draws
    cov = np.cov(out.T) * (1.0 + 1.0 / draws)
    return AngleErrorEffect("quantisation", step, out.mean(axis=0) - base, cov, draws, seen)
