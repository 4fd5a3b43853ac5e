"""Stiffness estimators on filtered signals.

| module | job |
|---|---|
| ``observer.py`` | the paper's update law (7), once: coefficients, recursion, informed samples |
| ``kalman.py`` | the Kalman model (elastic torque and stiffness as states), its likelihood and smoother |
| ``noise_search.py`` | the noise levels' bounds and the Nelder–Mead search over their logarithms |
| ``kernels.py`` | the sequential loops, compiled with numba |
| ``scan.py`` | the observer recursion as a blocked NumPy scan (the path without numba) |
| ``estimators.py`` | the three estimators behind ``--estimator``, their variance and the bands |
"""
