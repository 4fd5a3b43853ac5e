"""Unmodelled effects put in the identification's model: their torques in, their amplitudes out.

An effect whose torque is e = a·φ (a stretch reflex, a friction…) adds one column φ to the
model f = m·ÿ + b·ẏ + a·φ + s; its amplitude a is a linear coefficient like m and b, identified
with them (:func:`~limbstiff.mechanics.identification.identify_mechanics`). Which effects, at which
shape, is chosen above (:mod:`limbstiff.effects.in_model`); here they are arrays and names only.
Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..interval import Interval


@dataclass(frozen=True)
class EffectTerms:
    """The torques, per unit amplitude, of the effects put in the model.

    Parameters
    ----------
    names : tuple of str
        The effects (names of :data:`limbstiff.effects.registry.CANDIDATES`).
    shapes : tuple of Mapping
        Each one's shape parameters (SI units).
    amplitude_names : tuple of str
        The name of each one's amplitude (``gain``, ``friction_torque``…).
    units : tuple of str
        The unit of each amplitude.
    columns : ndarray, shape (k, n)
        Each one's torque per unit amplitude at the trial's samples, low-passed like the torque,
        N·m per unit amplitude.
    loglik_gains : tuple of float
        How much each raised the log marginal likelihood when it was chosen (at fixed noise
        levels; the profile of :mod:`limbstiff.effects.in_model`).
    alternatives : tuple of tuple of (float, ndarray)
        Each one's other shapes of comparable evidence: log marginal likelihood less the chosen
        shape's, and the column (n,) (:attr:`limbstiff.effects.in_model.ShapeProfile.alternatives`).
    shapes_tried : tuple of int
        The size of each one's grid of shapes.
    """

    names: tuple[str, ...]
    shapes: tuple[Mapping, ...]
    amplitude_names: tuple[str, ...]
    units: tuple[str, ...]
    columns: np.ndarray
    loglik_gains: tuple[float, ...] = ()
    alternatives: tuple = ()
    shapes_tried: tuple[int, ...] = ()

    def __len__(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class EffectFit:
    """One effect identified in the model: its shape and its amplitude's posterior.

    Parameters
    ----------
    name : str
    shape : Mapping
        Shape parameters (a reflex's delay in s, its direction, its activation corner in Hz…).
    amplitude_name : str
    unit : str
        Of the amplitude.
    amplitude : Interval
        Posterior median and interval of the amplitude.
    loglik_gain : float or None
        Log marginal likelihood gained by putting it in the model (at fixed noise levels).
    """

    name: str
    shape: Mapping
    amplitude_name: str
    unit: str
    amplitude: Interval
    loglik_gain: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready (``identification.effects`` of ``summary.json``)."""
        return {"name": self.name, "shape": {k: (None if v is None else float(v)) for k, v in self.shape.items()},
                "amplitude_name": self.amplitude_name, "unit": self.unit, "amplitude": self.amplitude.to_dict(),
                "loglik_gain": self.loglik_gain}


def effect_fits(terms: EffectTerms | None, draws: np.ndarray, level: float) -> tuple[EffectFit, ...]:
    """The identified effects from their amplitudes' draws (n_draws, k) at ``level``."""
    if terms is None:
        return ()
    gains = terms.loglik_gains or (None,) * len(terms)
    return tuple(EffectFit(name, shape, amp, unit, Interval.of_draws(draws[:, j], level), gain)
                 for j, (name, shape, amp, unit, gain) in enumerate(zip(terms.names, terms.shapes,
                                                                        terms.amplitude_names, terms.units, gains)))


def without_effects(torque: np.ndarray, terms: EffectTerms | None, amplitudes) -> np.ndarray:
    """The torque (n,) less the effects' torques at ``amplitudes`` (k,): what m, b and the spring
    are left to explain, N·m."""
    if terms is None or not len(terms):
        return torque
    return torque - np.asarray(amplitudes, dtype=float) @ terms.columns


def joined(*terms: EffectTerms | None) -> EffectTerms | None:
    """Several sets of terms as one, in order (None when there are none): the effects in the model
    and the stiffness curve's weights enter the model alike."""
    terms = tuple(t for t in terms if t is not None and len(t))
    if not terms:
        return None
    if len(terms) == 1:
        return terms[0]
    return EffectTerms(names=sum((t.names for t in terms), ()), shapes=sum((t.shapes for t in terms), ()),
                       amplitude_names=sum((t.amplitude_names for t in terms), ()),
                       units=sum((t.units for t in terms), ()), columns=np.vstack([t.columns for t in terms]),
                       loglik_gains=sum((t.loglik_gains or (None,) * len(t) for t in terms), ()))
