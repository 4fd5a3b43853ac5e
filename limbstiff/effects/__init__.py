"""The unmodelled effects: one registry for the simulator, the analysis and the diagnosis.

``registry`` (:data:`~limbstiff.effects.registry.EFFECTS`: each effect's simulation and model),
``simulated`` (what an effect adds to a simulation), ``channels`` (a trial's filtered signals as
the effects see them), ``kinds`` (how an effect enters the model: a torque, a corrected channel, an
offset of m or b) and ``candidates`` (the model's shapes and grids). ``limbstiff analyze --effect NAME`` puts a torque
effect of the library in the analysis's model (:mod:`limbstiff.effects.in_model`); ``limbstiff
diagnose`` tries every one held out. The physics shared with the simulator is
:mod:`limbstiff.unmodelled`. Pure numpy/scipy: no I/O.
"""
