"""Protocols: one TOML file per experimental set-up, read into a frozen :class:`Protocol`.

A protocol says how to read a lab's files (column names, units, scale and sign; delimiter,
decimal mark and unit row of text files; sample rate of MAT files without time), which
observer variant and estimator to run, the observer gain and derivative-filter settings, and
what is known of inertia and damping (fixed values or priors). Every setting left out takes
the default documented on :class:`Protocol`; ``None`` means "derive it from the data".
Unknown keys are an error, so a misspelt setting is never silently ignored.

The dataclasses and their checks are :mod:`limbstiff.protocol.settings`; reading the TOML file is
:mod:`limbstiff.protocol.reading`. Every public name is imported from here.
"""

from ..errors import ProtocolError
from .reading import load_protocol, protocol_from_dict
from .settings import (DECIMALS, DELIMITERS, DERIVATIVES, DISCRETISATIONS, ENSEMBLE_HOW, ENSEMBLE_MARKER, ESTIMATORS,
                       MODEL_EFFECTS, PRIOR_DISTRIBUTIONS, QUANTITIES, VARIANTS, Column, Cycles, Prior, Protocol)

__all__ = ["DECIMALS", "DELIMITERS", "DERIVATIVES", "DISCRETISATIONS", "ENSEMBLE_HOW", "ENSEMBLE_MARKER", "ESTIMATORS",
           "MODEL_EFFECTS",
           "PRIOR_DISTRIBUTIONS", "QUANTITIES", "VARIANTS", "Column", "Cycles", "Prior", "Protocol",
           "ProtocolError", "load_protocol", "protocol_from_dict"]
