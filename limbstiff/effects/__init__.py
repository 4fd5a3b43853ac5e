"""The unmodelled effects a model can hold: one library for the analysis and the diagnosis.

``channels`` (a trial's filtered signals as the effects see them), ``kinds`` (how an effect enters
the model: a torque, a corrected channel, an offset of m or b) and ``candidates`` (the library,
:data:`~limbstiff.effects.candidates.CANDIDATES`). ``limbstiff analyze --effect NAME`` puts a torque
effect of the library in the analysis's model (:mod:`limbstiff.effects.in_model`); ``limbstiff
diagnose`` tries every one held out. The physics shared with the simulator is
:mod:`limbstiff.unmodelled`. Pure numpy/scipy: no I/O.
"""
