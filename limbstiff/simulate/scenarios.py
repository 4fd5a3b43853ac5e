"""The named scenarios and the checking of their parameters.

Every scenario takes ``fs`` (Hz), ``duration`` (s), ``torque_noise`` (sd of Gaussian noise on
the recorded torque/force, N·m or N) and ``encoder_counts`` (counts/rev of the angle
quantisation, 0 = none) — or ``position_resolution`` (m) for translational scenarios. The
builders live in :mod:`.paper` (Grioli & Bicchi 2010), :mod:`.limbs` (human joints) and
:mod:`.devices` (joints seen through a device: compliant coupling, moving platform).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Callable, Mapping

from .devices import DEVICES
from .limbs import LIMBS
from .paper import PAPER


@dataclass(frozen=True)
class Scenario:
    """A named simulation scenario.

    Attributes
    ----------
    name : str
    kind : {"rotational", "translational"}
    description : str
        One line.
    defaults : Mapping[str, float]
        Every parameter the scenario takes, with its default (SI units).
    build : callable (params, rng) -> Setup
        Its docstring documents the model, the paper section and the motion obtained.
    """

    name: str
    kind: str
    description: str
    defaults: Mapping[str, float]
    build: Callable = field(repr=False)

    @property
    def doc(self) -> str:
        """Documentation of the model (the builder's docstring)."""
        return self.build.__doc__ or ""


#: Parameters every scenario takes, listed first.
COMMON = ("fs", "duration", "torque_noise", "encoder_counts", "position_resolution")


def _ordered(defaults: Mapping[str, float]) -> Mapping[str, float]:
    keys = [k for k in COMMON if k in defaults] + [k for k in defaults if k not in COMMON]
    return MappingProxyType({k: float(defaults[k]) for k in keys})


SCENARIOS: dict[str, Scenario] = {
    name: Scenario(name=name, kind=kind, description=description, defaults=_ordered(defaults),
                   build=build)
    for name, kind, description, defaults, build in PAPER + LIMBS + DEVICES
}


def merge_params(what: str, defaults: Mapping[str, float],
                 given: Mapping[str, float] | None) -> dict[str, float]:
    """Defaults overridden by ``given``; unknown keys or non-numbers are a ``ValueError``.

    Parameters
    ----------
    what : str
        What the parameters belong to, for the message (``"scenario 'elbow'"``).
    """
    merged = dict(defaults)
    for key, value in (given or {}).items():
        if key not in defaults:
            raise ValueError(f"unknown parameter '{key}' for {what}; accepted: "
                             + ", ".join(sorted(defaults)))
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"parameter '{key}' of {what} must be a number, got {value!r}") \
                from None
        if not math.isfinite(value):
            raise ValueError(f"parameter '{key}' of {what} must be finite, got {value}")
        merged[key] = value
    return merged


def check_common(what: str, params: Mapping[str, float]) -> None:
    """Check the parameters every scenario shares."""
    for key in ("fs", "duration"):
        if not params[key] > 0:
            raise ValueError(f"parameter '{key}' of {what} must be positive, got {params[key]:g}")
    for key in ("torque_noise", "encoder_counts", "position_resolution"):
        if key in params and params[key] < 0:
            raise ValueError(f"parameter '{key}' of {what} must be >= 0, got {params[key]:g}")


def lookup(name: str) -> Scenario:
    """The scenario called ``name``, or a ``ValueError`` listing the names."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; available: "
                         + ", ".join(SCENARIOS)) from None
