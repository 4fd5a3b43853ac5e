"""Inertia and damping identified from the trial itself.

| module | job |
|---|---|
| ``least_squares.py`` | windowed least squares (the starting point, and a cross-check) |
| ``likelihood.py`` | the Kalman model's marginal likelihood of the noise levels, m and b integrated out |
| ``posterior.py`` | the emcee posterior of (m, b, noise levels), with its diagnostics |
| ``chain.py`` | the emcee chain over the log noise levels: adaptation, blocks until long enough, fallback |
| ``identification.py`` | :func:`identify_mechanics`: the three in turn, one typed result |
"""
