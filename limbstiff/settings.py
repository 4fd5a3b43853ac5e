"""The settings of one analysis that the protocol leaves open, derived from the trial's data.

The observer gain α, the speed below which nothing moves, the observability window
(:class:`DerivedSettings`), and the samples the motion informs under them
(:func:`informed_by_motion`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import TrialError
from .estimate import observer
from .filtered import Filtered
from .protocol import Protocol

#: Default memory of the observer, as a fraction of the range of motion: by (8) the estimate
#: forgets its past as exp(−α·path), so 1/α is the path over which it averages the local slope.
MEMORY_FRACTION_OF_RANGE = 1 / 20
#: Speeds below this multiple of the velocity noise level count as no motion.
VELOCITY_NOISE_MULTIPLE = 3.0
#: Observability window, in periods of the typical motion frequency.
OBSERVABLE_PERIODS = 2.0


@dataclass(frozen=True)
class DerivedSettings:
    """Settings of one analysis that the protocol left open and the trial's data decided.

    Parameters
    ----------
    observer_gain : float, 1/rad (1/m)
        α; by (8) the observer forgets its past over a path of 1/α.
    discretisation : {"exact", "euler"}
    range_of_motion : float, rad (m)
        Span of the central 95 % of the angle.
    velocity_threshold : float, rad/s (m/s)
        Speeds below it count as no motion.
    observable_window_s : float, s
        Window over which recent motion must inform the estimate.
    """

    observer_gain: float
    discretisation: str
    range_of_motion: float
    velocity_threshold: float
    observable_window_s: float

    @property
    def observer_memory(self) -> float:
        """1/α, rad (m)."""
        return 1.0 / self.observer_gain


def range_of_motion(angle: np.ndarray) -> float:
    """Span of the central 95 % of the angle, rad (m): robust to spikes and drift ends."""
    return float(np.subtract(*np.percentile(angle, [97.5, 2.5])))


def default_gain(angle: np.ndarray) -> float:
    """Observer gain α from the data: memory 1/α of :data:`MEMORY_FRACTION_OF_RANGE` of the range, 1/rad (1/m)."""
    return 1.0 / (MEMORY_FRACTION_OF_RANGE * range_of_motion(angle))


def derive_settings(filtered: Filtered, protocol: Protocol, *, where: str = "trial") -> DerivedSettings:
    """Observer gain, velocity threshold and observability window from the data (or the protocol).

    Raises
    ------
    TrialError
        When the angle does not change.
    """
    range_ = range_of_motion(filtered.angle)
    if not range_ > 0:
        raise TrialError(where, "no motion: the angle does not change")
    return DerivedSettings(observer_gain=protocol.observer_gain or default_gain(filtered.angle),
                           discretisation=protocol.discretisation, range_of_motion=range_,
                           velocity_threshold=VELOCITY_NOISE_MULTIPLE * filtered.velocity_noise,
                           observable_window_s=OBSERVABLE_PERIODS / filtered.motion_hz)


def informed_by_motion(filtered: Filtered, derived: DerivedSettings,
                       bridged: np.ndarray | None = None) -> np.ndarray:
    """The samples the recent motion informs, shape (n,) of bool: none within the chain's edge
    (derivatives unreliable there), nor where ``bridged`` (interpolated across a gap in the file)."""
    informed = observer.informed(filtered.velocity, observer_gain=derived.observer_gain,
                                 sample_period=filtered.sample_period, window=derived.observable_window_s,
                                 velocity_threshold=derived.velocity_threshold)
    edge = filtered.edge
    informed[:edge] = informed[len(informed) - edge:] = False
    if bridged is not None and len(bridged) == len(informed):
        informed &= ~bridged
    return informed
