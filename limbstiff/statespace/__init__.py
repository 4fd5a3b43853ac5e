"""The state-space (Kalman) model every estimate, identification, check and diagnosis uses.

See :mod:`limbstiff.statespace.steps` for the model's equations.
"""
