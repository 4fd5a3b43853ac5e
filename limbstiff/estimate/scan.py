"""The observer's first-order linear recursion as a vectorised, blocked scan in pure NumPy.

x[k] = a[k]·x[k−1] + c[k] with 0 ≤ a[k] ≤ 1 (the exact discretisation, a = exp(−α·|ẏ|·Ts)):
within a block the decay D[k] = −Σ ln a[i] turns the recursion into cumulative sums,

    x[k] = e^(−D[k]) · (x[s−1] + Σ_{j=s..k} c[j]·e^(D[j])),

which stay in floating-point range as long as D grows by less than :data:`MAX_BLOCK_DECAY`
within a block. The state carried from block to block obeys the same recursion on one value per
block, so it is solved by the same function, one level up, until a few values are left. Each
level is a handful of passes over the data: no Python loop over samples.

This is the reference path (and the path without numba); :mod:`limbstiff.statespace.kernels` holds the
compiled loop the tests compare it with. Pure numpy.
"""

from __future__ import annotations

import numpy as np

#: Largest decay ∫α|ẏ|dt inside one block: e^600 ≈ 10^260 is still a finite float64.
MAX_BLOCK_DECAY = 600.0
#: Decay of one step is capped here: a below e^-36 ≈ 2.3·10^-16 is taken as e^-36, so the state
#: carried over such a step leaks in by at most 2.3·10^-16 of itself (a = 0 forgets it exactly).
MAX_STEP_DECAY = 36.0
#: Longest block: the rounding error of a cumulative sum grows with its length.
MAX_BLOCK = 1024
#: Below this many values the carry is run as a plain loop.
DIRECT = 64


def linear_recursion(a: np.ndarray, c: np.ndarray, initial: float = 0.0) -> np.ndarray:
    """Run x[k] = a[k]·x[k−1] + c[k] with x[−1] = ``initial``, for 0 ≤ a ≤ 1.

    Parameters
    ----------
    a : ndarray, shape (n,)
        Decay factors in [0, 1].
    c : ndarray, shape (n,)
    initial : float

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    ValueError
        When some a lies outside [0, 1] (forward Euler with a large gain): use the loop in
        :mod:`limbstiff.statespace.kernels` for those.
    """
    a = np.asarray(a, dtype=float)
    c = np.asarray(c, dtype=float)
    if a.shape != c.shape or a.ndim != 1:
        raise ValueError("a and c must be one-dimensional arrays of the same length")
    if a.size and not (np.min(a) >= 0.0 and np.max(a) <= 1.0):
        raise ValueError("the blocked scan needs 0 <= a <= 1 (a stable recursion)")
    with np.errstate(divide="ignore"):
        decay = np.minimum(-np.log(a), MAX_STEP_DECAY)
    return _scan(decay, c, float(initial))


def _scan(decay: np.ndarray, c: np.ndarray, initial: float) -> np.ndarray:
    n = decay.size
    if n <= DIRECT:
        return _loop(np.exp(-decay), c, initial)
    # every level shrinks the problem at least MAX_BLOCK_DECAY / MAX_STEP_DECAY = 16-fold
    block = int(min(MAX_BLOCK, MAX_BLOCK_DECAY // max(float(decay.max()), 1e-300)))
    rows = -(-n // block)
    pad = rows * block - n
    d = np.concatenate([decay, np.zeros(pad)]).reshape(rows, block)
    cc = np.concatenate([c, np.zeros(pad)]).reshape(rows, block)
    d = np.cumsum(d, axis=1)                                   # D[k] within each block
    y = np.cumsum(cc * np.exp(d), axis=1)
    y *= np.exp(-d)                                            # each block started from x = 0
    # state at each block's end: X_b = e^(−D_end,b)·X_{b−1} + y_end,b — the same recursion
    ends = _scan(np.minimum(d[:, -1], MAX_STEP_DECAY), y[:, -1].copy(), initial)
    before = np.concatenate([[initial], ends[:-1]])
    y += np.exp(-d) * before[:, None]
    return y.reshape(-1)[:n]


def _loop(a: np.ndarray, c: np.ndarray, initial: float) -> np.ndarray:
    out = np.empty(a.size)
    x = initial
    for k in range(a.size):
        x = a[k] * x + c[k]
        out[k] = x
    return out
