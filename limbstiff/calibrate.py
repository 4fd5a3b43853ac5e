"""Spring calibration for ground truth on a bench (Grioli & Bicchi 2010, Sec. V).

Force–displacement pairs (x, f) of one spring are fitted in semi-logarithmic space,
ln f = m·x + q, which gives the exponential spring f = e^q·e^{m·x} (the paper's s(y) = a·e^{b·y}
with a = e^q and b = m), its stiffness σ(x) = m·e^q·e^{m·x}, and a relative error margin of the
model. The paper writes that margin as r = 1 − e^{SME} with SME the error of the regression;
taken with SME the root-mean-square residual of ln f, its magnitude e^{SME} − 1 is the typical
relative deviation of a measured force from the curve (about 25 % on the paper's bench,
because of hysteresis). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SpringCalibration:
    """An exponential spring f = a·e^{b·x} fitted to calibration pairs.

    Parameters
    ----------
    a : float, N (N·m)
        Force at x = 0 (e^q).
    b : float, 1/m (1/rad)
        Exponential rate (the regression slope m).
    rms_log_error : float
        Root-mean-square residual of ln f (the paper's SME).
    error_margin : float
        Relative error margin e^{SME} − 1 (magnitude of the paper's r = 1 − e^{SME}).
    n_pairs : int
        Pairs used.
    x_range : tuple of float, m (rad)
        Range of displacement the calibration covers.
    kind : {"translational", "rotational"} or None
        Whether x is a length and f a force (the paper's bench) or an angle and a torque; None
        for a calibration file written before it was recorded (then not checked against trials).
    """

    a: float
    b: float
    rms_log_error: float
    error_margin: float
    n_pairs: int
    x_range: tuple[float, float]
    kind: str | None = "translational"

    def force(self, x: np.ndarray) -> np.ndarray:
        """Spring force f(x) = a·e^{b·x}."""
        return self.a * np.exp(self.b * np.asarray(x, dtype=float))

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        """Stiffness σ(x) = a·b·e^{b·x}."""
        return self.a * self.b * np.exp(self.b * np.asarray(x, dtype=float))

    @property
    def units(self) -> dict[str, str]:
        """SI unit of each number of :meth:`to_dict` (``1``: dimensionless)."""
        from .trial import SI_UNITS
        if self.kind is None:
            return {}
        u = SI_UNITS[self.kind]
        return {"a": u["torque"], "b": f"1/{u['angle']}", "x_range": u["angle"], "rms_log_error": "1",
                "error_margin": "1", "stiffness": u["stiffness"]}

    def to_dict(self) -> dict:
        return {"model": "exponential", "kind": self.kind, "a": self.a, "b": self.b,
                "rms_log_error": self.rms_log_error, "error_margin": self.error_margin,
                "n_pairs": self.n_pairs, "x_range": list(self.x_range), "units": self.units}

    @classmethod
    def from_dict(cls, d: dict) -> "SpringCalibration":
        return cls(a=float(d["a"]), b=float(d["b"]), rms_log_error=float(d["rms_log_error"]),
                   error_margin=float(d["error_margin"]), n_pairs=int(d["n_pairs"]),
                   x_range=(float(d["x_range"][0]), float(d["x_range"][1])),
                   kind=_kind(d.get("kind")))


def _kind(value) -> str | None:
    """A calibration file's ``kind``, checked (None when the file has none)."""
    if value not in (None, "translational", "rotational"):
        raise ValueError(f"kind must be 'translational' or 'rotational', not {value!r}")
    return value


def fit_exponential_spring(displacement: np.ndarray, force: np.ndarray, *,
                           kind: str = "translational") -> SpringCalibration:
    """Regression of ln f on x (Sec. V).

    Parameters
    ----------
    displacement : ndarray, shape (n,), m (rad)
    force : ndarray, shape (n,), N (N·m); strictly positive
    kind : {"translational", "rotational"}
        Length and force, or angle and torque (carried into the calibration's units).

    Returns
    -------
    SpringCalibration

    Raises
    ------
    ValueError
        Fewer than 3 pairs, non-positive forces, or no spread in displacement.
    """
    x = np.asarray(displacement, dtype=float)
    f = np.asarray(force, dtype=float)
    if x.shape != f.shape or x.ndim != 1:
        raise ValueError("displacement and force must be 1-D arrays of the same length")
    if x.size < 3:
        raise ValueError(f"at least 3 force–displacement pairs are needed, got {x.size}")
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(f)):
        raise ValueError("calibration pairs must be finite numbers")
    if np.any(f <= 0):
        raise ValueError("an exponential spring needs strictly positive forces "
                         f"({int(np.sum(f <= 0))} pairs are ≤ 0)")
    if np.ptp(x) == 0:
        raise ValueError("all pairs have the same displacement")
    slope, intercept = np.polyfit(x, np.log(f), 1)
    resid = np.log(f) - (slope * x + intercept)
    sme = float(np.sqrt(np.mean(resid ** 2)))
    return SpringCalibration(a=float(np.exp(intercept)), b=float(slope), rms_log_error=sme,
                             error_margin=float(np.expm1(sme)), n_pairs=int(x.size),
                             x_range=(float(x.min()), float(x.max())), kind=kind)
