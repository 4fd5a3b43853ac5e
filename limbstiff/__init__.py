"""limbstiff: non-invasive stiffness measurement of limbs and variable-stiffness actuators.

Built on the stiffness observer of Grioli & Bicchi (RSS 2010). The public API is imported
lazily so that ``import limbstiff`` (and ``limbstiff --help``) stay fast; ``dir(limbstiff)`` and
``__all__`` list it::

    import limbstiff
    result = limbstiff.analyze("examples/elbow.csv", "protocols/elbow-lab.toml")
    result.to_frame()
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_API = {
    "Trial": "limbstiff.trial",
    "Protocol": "limbstiff.protocol",
    "load_protocol": "limbstiff.protocol",
    "read_trial": "limbstiff.files",
    "write_trial": "limbstiff.files",
    "LimbstiffError": "limbstiff.errors",
    "TrialError": "limbstiff.errors",
    "ProtocolError": "limbstiff.errors",
    "simulate": "limbstiff.simulate",
    "analyze": "limbstiff.analysis",
    "StiffnessResult": "limbstiff.result",
    "write_report": "limbstiff.report",
    "analyze_files": "limbstiff.batch.jobs",
    "identify_files": "limbstiff.batch.jobs",
    "diagnose": "limbstiff.diagnosis.run",
    "diagnose_files": "limbstiff.diagnosis.from_files",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'limbstiff' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public API (:data:`__all__`), as ``dir(limbstiff)`` and tab completion show it."""
    return sorted(__all__)
