"""The live stiffness of a stream (``limbstiff stream``): the analysis's Kalman model run causally.

``kernel`` (the compiled chain), ``estimator`` (:class:`LiveModel`, :class:`LiveEstimator`),
``identify`` (what the record so far gives: corner, m and b, noise levels), ``checks`` (what can
be checked causally), ``session`` (:class:`LiveSession`: gaps, breaks, identifications, what to
publish), ``latency``, ``status`` (the terminal line) and ``run`` (:func:`run_stream`: LSL in and
out, the recording, the analysis at the end). See docs/usage.md, "Live".
"""
