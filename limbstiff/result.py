"""Results of a stiffness analysis, as first-class objects.

A :class:`StiffnessResult` holds the stiffness course of one trial with its band and
observability, the inertia and damping used, and every setting that produced them. It turns
itself into the contract's outputs: :meth:`StiffnessResult.to_frame` (the rows of
``stiffness.csv``) and :meth:`StiffnessResult.summary` (``summary.json``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from . import __version__
from .provenance import dependency_versions, settings_hash
from .trial import Trial


@dataclass(frozen=True)
class Interval:
    """A value with its central credible interval.

    Parameters
    ----------
    median, lo, hi : float
        Median and bounds, in the quantity's SI unit.
    """

    median: float
    lo: float
    hi: float

    @classmethod
    def fixed(cls, value: float) -> "Interval":
        """A value known exactly (given by the user or the protocol)."""
        return cls(float(value), float(value), float(value))

    def to_dict(self) -> dict:
        return {"median": self.median, "lo": self.lo, "hi": self.hi}


@dataclass(frozen=True)
class StiffnessResult:
    """Stiffness of one trial.

    Parameters
    ----------
    trial : Trial
        The trial analysed.
    variant : {"external", "direct"}
    estimator : str
    stiffness : ndarray, shape (n,), N·m/rad (N/m)
    stiffness_lo, stiffness_hi : ndarray, shape (n,), N·m/rad (N/m)
        Bounds of the central band at ``ci_level``.
    observable : ndarray of bool, shape (n,)
        True where the estimate is informed by recent motion.
    inertia, damping : Interval or None
        Used by the external variant (None for the direct variant).
    ci_level : float
    seed : int
    settings : Mapping[str, Any]
        The resolved protocol (file settings with command-line overrides).
    details : Mapping[str, Any]
        What was derived from the data: observer gain, bandwidth, thresholds, identification.
    warnings : tuple of str
    reference : ndarray, shape (n,), or None
        Reference stiffness (``stiffness_true`` or a calibration), for validation.
    posterior : posterior.Posterior or None
        Draws of (m, b, noise levels) when m and b were identified (for the report's pairwise
        plot); None when both were given or for the direct variant.
    """

    trial: Trial
    variant: str
    estimator: str
    stiffness: np.ndarray
    stiffness_lo: np.ndarray
    stiffness_hi: np.ndarray
    observable: np.ndarray
    inertia: Interval | None
    damping: Interval | None
    ci_level: float
    seed: int
    settings: Mapping[str, Any] = field(default_factory=dict)
    details: Mapping[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    reference: np.ndarray | None = None
    posterior: Any = None

    @property
    def observable_fraction(self) -> float:
        """Share of samples where the estimate is informed by motion."""
        return float(np.mean(self.observable))

    def to_frame(self):
        """The per-sample table of ``stiffness.csv`` as a :class:`pandas.DataFrame`."""
        import pandas as pd

        return pd.DataFrame({
            "time_s": self.trial.time,
            "stiffness": self.stiffness,
            "stiffness_lo": self.stiffness_lo,
            "stiffness_hi": self.stiffness_hi,
            "observable": self.observable.astype(int),
        })

    def reference_error(self, *, skip: float = 2.0) -> dict | None:
        """Relative error against the reference stiffness, over observable samples after ``skip`` s.

        Returns
        -------
        dict or None
            ``median`` and ``p90`` of |σ̂ − σ|/|σ|, ``coverage`` of the band, and ``n`` samples
            used; None without a reference.
        """
        if self.reference is None:
            return None
        use = self.observable & (self.trial.time - self.trial.time[0] >= skip) & (self.reference != 0)
        if not np.any(use):
            return {"median": None, "p90": None, "coverage": None, "n": 0}
        rel = np.abs(self.stiffness[use] - self.reference[use]) / np.abs(self.reference[use])
        inside = (self.stiffness_lo[use] <= self.reference[use]) & (self.reference[use] <= self.stiffness_hi[use])
        return {"median": float(np.median(rel)), "p90": float(np.percentile(rel, 90)),
                "coverage": float(np.mean(inside)), "n": int(use.sum())}

    def summary(self) -> dict:
        """The content of ``summary.json`` (INTERFACE.md section 4), JSON-ready."""
        obs = self.observable if np.any(self.observable) else np.ones_like(self.observable)
        stiffness = {
            "median": float(np.median(self.stiffness[obs])),
            "lo": float(np.median(self.stiffness_lo[obs])),
            "hi": float(np.median(self.stiffness_hi[obs])),
            "min": float(np.min(self.stiffness[obs])),
            "max": float(np.max(self.stiffness[obs])),
        }
        trial = self.trial
        return {
            "trial": trial.name,
            "source": trial.source,
            "source_sha256": trial.source_sha256,
            "variant": self.variant,
            "estimator": self.estimator,
            "kind": trial.kind,
            "fs_hz": trial.fs,
            "n_samples": trial.n_samples,
            "duration_s": trial.duration,
            "ci_level": self.ci_level,
            "inertia": None if self.inertia is None else self.inertia.to_dict(),
            "damping": None if self.damping is None else self.damping.to_dict(),
            "stiffness": stiffness,
            "observable_fraction": self.observable_fraction,
            "mcmc": _jsonable((self.details.get("identification") or {}).get("mcmc")),
            "reference_error": self.reference_error(),
            "warnings": list(self.warnings),
            "units": dict(trial.units),
            "seed": self.seed,
            "software": software(),
            "metadata": dict(trial.metadata),
            "details": _jsonable(self.details),
            "settings": _jsonable(self.settings),
            "settings_sha256": settings_hash(_jsonable(self.settings), length=64),
        }


def software() -> dict:
    """limbstiff's name and version, the Python version and the dependencies' versions."""
    import platform
    return {"name": "limbstiff", "version": __version__, "python": platform.python_version(),
            "dependencies": dependency_versions()}


def _jsonable(value):
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
