"""Does the model fit this recording? Checks on every analysis, and the verdict they give.

| module | job |
|---|---|
| ``model.py`` | what is measured on the analysis's own model: held-out torque, innovations, slopes |
| ``verdict.py`` | ``Check``, ``ModelChecks``, the thresholds with their reasons, the verdict |
| ``analysis.py`` | :func:`check_analysis`: every check of one analysis |
| ``units.py`` | a trial's units and ranges against its limb: an error, or ``units_*`` checks |
"""

from __future__ import annotations

from .analysis import check_analysis
from .verdict import CAUTION, OK, UNRELIABLE, Check, ModelChecks, Verdict

__all__ = ["check_analysis", "Check", "ModelChecks", "Verdict", "OK", "CAUTION", "UNRELIABLE"]
