"""Stiffness as a function of a movement cycle's phase or of a recorded variable (issue 36).

An ensemble of repeated cycles (``[cycles]``) or a trial whose operating point is recorded as its
own channel (``[columns.schedule]``) is analysed with the stiffness σ(t) = curve(u(t)) + walk(t):
a curve over the phase or the schedule shared by all cycles (:mod:`.basis`), at a resolution
chosen by held-out prediction of whole cycles (:mod:`.resolution`), identified with m and b in the
analysis's own model (:mod:`.fit`), reported pooled by bins with the band of the same posterior
(:mod:`.curve`), and checked (:mod:`.checks`). The trial is prepared by :mod:`.prepare`.
"""

from .curve import ScheduleCurve
from .prepare import ScheduleInput, schedule_input

__all__ = ["ScheduleCurve", "ScheduleInput", "schedule_input"]
