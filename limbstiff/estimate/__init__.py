"""Stiffness estimators on filtered signals.

| module | job |
|---|---|
| ``observer.py`` | the paper's update law (7), once: coefficients, recursion, informed samples |
| ``kalman.py`` | the Kalman model (elastic torque and stiffness as states), its likelihood and smoother |
| ``scan.py`` | the observer recursion as a blocked NumPy scan (the path without numba) |
| ``estimators.py`` | the three estimators behind ``--estimator``, their variance and the bands |
"""
