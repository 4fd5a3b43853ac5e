"""Units and ranges of a trial checked against its limb (issue 34): the analysis's side of
:mod:`limbstiff.plausibility`.

An impossible value stops the analysis with a one-line :class:`~limbstiff.errors.TrialError`;
an implausible one, and an identified inertia far outside the limb's range, is a failed check of
severity ``unreliable`` named ``units_<finding>``.
"""

from __future__ import annotations

from .. import plausibility
from ..errors import TrialError
from ..mechanics.identification import Identification
from ..protocol import Protocol
from ..trial import Trial
from .verdict import UNRELIABLE, Check, ModelChecks

Findings = tuple[plausibility.Finding, ...]


def plausible(trial: Trial, protocol: Protocol) -> Findings:
    """The units and ranges of a trial checked against its limb, before any fit.

    Parameters
    ----------
    trial : Trial
    protocol : Protocol
        Its ``limb`` gives the bounds (any joint's when None).

    Returns
    -------
    tuple of Finding
        The implausible values (each gives the verdict ``unreliable``).

    Raises
    ------
    TrialError
        For an impossible one (a sample rate, angle or torque no limb has), naming the likely
        unit and the protocol line that fixes it; for a constant angle or torque (none recorded).
    """
    torque = trial.torque if trial.torque is not None else trial.elastic_torque
    found = plausibility.check_recording(trial.time, trial.angle, torque, rotational=trial.kind == "rotational",
                                         limb=plausibility.limb_named(protocol.limb), written=_written(trial, protocol))
    if found and found[0].fatal:
        raise TrialError(trial.source or trial.name, found[0].message)
    return found


def _written(trial: Trial, protocol: Protocol) -> dict[str, str]:
    """The units the angle and the torque were written in (the file's, else the protocol's): what
    an advice never names as the fix."""
    column = "torque" if trial.torque is not None else "elastic_torque"
    stated = {q: trial.units_written.get(c) or getattr(protocol.columns.get(c), "unit", None)
              for q, c in (("angle", "angle"), ("torque", column))}
    return {q: u for q, u in stated.items() if u}


def implausible_inertia(trial: Trial, protocol: Protocol, ident: Identification | None,
                        found: Findings) -> Findings:
    """The findings before the fit, plus an identified inertia far outside the limb's range.

    Its bounds: the protocol's ``limb``, else its ``expected_inertia`` or lognormal prior, else
    any joint's (:func:`limbstiff.plausibility.limb_of`). The inertia gives the verdict
    ``unreliable``, not an error: it is identified with an uncertainty and an unusual attachment
    can be real, so the clinician still sees the numbers, marked as not to be used, with the unit
    to check named in the reason. A given (not identified) inertia is not judged, nor one that
    follows from an angle or torque range already found too small or too large (that finding
    says what to check; the inertia's unit guess would contradict it).
    """
    if ident is None or ident.given or trial.kind != "rotational":
        return found
    if any(f.name in ("angle_range", "torque_range") for f in found):
        return found
    prior = protocol.inertia_prior
    limb = plausibility.limb_of(protocol.limb, expected_inertia=protocol.inertia_range,
                                prior=(prior.median, prior.sigma) if prior.distribution == "lognormal" else None)
    inertia = plausibility.check_inertia(ident.inertia.median, limb=limb, written=_written(trial, protocol))
    return found if inertia is None else (*found, inertia)


def units_checks(checks: ModelChecks, found: Findings) -> ModelChecks:
    """The analysis's checks with each finding added as a failed ``units_<name>`` check (``unreliable``)."""
    return ModelChecks(checks.checks + tuple(Check(f"units_{f.name}", None, None, False, f.message, UNRELIABLE)
                                             for f in found))
