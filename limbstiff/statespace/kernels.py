"""The sequential recursions of the estimators, compiled with numba when it is available.

Each kernel is written once, as a plain loop over numpy arrays that both CPython and numba
run. With numba installed the module exports the compiled versions (``cache=True``, so the
compilation of a few seconds happens once per installation); without it, or with the
environment variable ``LIMBSTIFF_NO_JIT=1``, the same source runs in CPython. The reference
(``<kernel>.py_func`` when compiled) is what the tests compare the compiled code against.

Kernels: the first-order linear recursion of the observer, and the two-state Kalman model of
:mod:`limbstiff.statespace`. Its covariance step is written once (:func:`_predict`,
:func:`_update`), one step of the model on any number of measurement channels once
(:func:`step`, which the live chain calls too, with its fading memory), and the forward pass once
(:func:`_forward`): its outputs — the log-likelihood, the filtered moments, each channel's
innovations, the quadratic form of the likelihood in the channels' weights
(:mod:`limbstiff.statespace.linear`) — are chosen by the flags :data:`LOGLIK`, :data:`MOMENTS`,
:data:`INNOVATIONS` and :data:`QUADRATIC`. Each variant is a thin wrapper into which numba inlines
the pass with its flags constant, so that a variant runs only its own code. Then the
Rauch–Tung–Striebel smoother (in place) and the closed form of the marginal likelihood of two
coefficients.
"""

from __future__ import annotations

import math
import os

import numpy as np


def linear_recursion(a, c, initial):
    """x[k] = a[k]·x[k−1] + c[k], x[−1] = initial; returns x, shape (n,)."""
    n = a.shape[0]
    out = np.empty(n)
    x = initial
    for k in range(n):
        x = a[k] * x + c[k]
        out[k] = x
    return out


def _predict(p11, p12, p22, di, gi, qs, qk, qc):
    """Covariance [p11, p12, p22] of the state [s, σ] one step ahead: F·P·Fᵀ + Q with
    F = [[1, di], [0, 1]] (ds = σ·dy) and Q = diag(qs, qk) + qc·[[gi², gi], [gi, 1]] (a
    stiffness change w_c moves the elastic torque by gi·w_c, gi the spring's deflection)."""
    return (p11 + 2.0 * di * p12 + di * di * p22 + qs + qc * gi * gi, p12 + di * p22 + qc * gi,
            p22 + qk + qc)


def _update(p11, p12, p22, r):
    """Measurement update of z = s + v, var(v) = r: the innovation variance S, the gains of s
    and σ, and the updated covariance."""
    sv = p11 + r
    g1 = p11 / sv
    g2 = p12 / sv
    return sv, g1, g2, p11 - g1 * p11, p12 - g1 * p12, p22 - g2 * p12


#: Outputs of :func:`_forward`, combined with ``|``: channel 0's log-likelihood, its filtered
#: moments, every channel's innovations with their variance, and the quadratic form with Σ ln S.
LOGLIK, MOMENTS, INNOVATIONS, QUADRATIC = 1, 2, 4, 8


def step(mean, e, row, chans, i, p11, p12, p22, d, g, noise, predict, observe):
    """One step of the model on every measurement channel: the prediction over the increment
    ``d``, then the update with row ``i`` of the channels. The covariance does not depend on the
    data, so the channels share it and its gains.

    Parameters
    ----------
    mean : ndarray, shape (2·c,)
        [s, σ] of each channel in turn (N·m, N·m/rad), updated in place; row ``row`` of ``e``
        (k, c) is written with each channel's innovation when ``observe``.
    chans : ndarray, shape (m, c)
        The measurement channels, any layout; this step's are row ``i``.
    p11, p12, p22 : float
        The covariance of [s, σ] before the step; ``d``, ``g`` the angle's increment and the
        spring's deflection at this step (rad, m).
    noise : tuple of 5 floats
        (R, Q_s·Δt, Q_σ·Δt, Q_c·Δt) of :meth:`~limbstiff.statespace.noise.NoiseLevels.per_step`,
        then the stiffness's fading memory 1/λ − 1 (λ = exp(−Δt/T), T the memory; 0 for none, as
        offline): σ's variance grows by 1/λ per step on top of the walk.
    predict : bool
        False at a (re)start: the state is the prior, observed without a prediction.
    observe : bool
        False where the measurement is missing: the state is only predicted.

    Returns
    -------
    p11, p12, p22 : float
        The covariance after the step.
    variance : float
        The innovations' variance S, (N·m)² (0 when not observed).
    """
    nc = e.shape[1]
    if predict:
        for c in range(nc):
            mean[2 * c] += mean[2 * c + 1] * d
        p11, p12, p22 = _predict(p11, p12, p22, d, g, noise[1], noise[2], noise[3])
        if noise[4] != 0.0:
            # P ← D·P·D, D = diag(1, 1/√λ)
            p12 = p12 * math.sqrt(1.0 + noise[4])
            p22 = p22 * (1.0 + noise[4])
    sv = 0.0
    if observe:
        sv, g1, g2, p11, p12, p22 = _update(p11, p12, p22, noise[0])
        for c in range(nc):
            ec = chans[i, c] - mean[2 * c]
            e[row, c] = ec
            mean[2 * c] += g1 * ec
            mean[2 * c + 1] += g2 * ec
    return p11, p12, p22, sv


def _forward(d, g, chans, mean0, cov0, noise, restart, observed, what, moments, covs, innovations, variance, quad):
    """The forward (causal) pass of the model: :func:`step` at every step over the channels
    ``chans`` (m, c, any layout: numba compiles each), from the prior [s, σ] of each channel
    ``mean0`` (2·c,) and covariance ``cov0`` (3-tuple). At a ``restart`` (bool (m,); empty: never)
    the state restarts at the step's data with the prior's σ and covariance; where ``observed``
    (bool (m,); empty: everywhere) is False the state is only predicted. ``d``, ``g`` and
    ``noise`` as :func:`step`.

    The flags ``what`` (:data:`LOGLIK`, :data:`MOMENTS`, :data:`INNOVATIONS`, :data:`QUADRATIC`,
    combined with ``|``) choose the outputs: with MOMENTS channel 0's filtered [s, σ] and
    covariance are written to ``moments`` (m, 2) and ``covs`` (m, 3) (predicted where not
    observed); with INNOVATIONS each channel's innovations and their variance S to
    ``innovations`` (m, c) and ``variance`` (m,); with QUADRATIC Σ e·eᵀ/S is added to ``quad``
    (c, c). Returns channel 0's log-likelihood with LOGLIK, Σ ln S with QUADRATIC (both over the
    observed steps), 0 otherwise.
    """
    nc = chans.shape[1]
    mean = mean0.copy()
    e = innovations if what & INNOVATIONS else np.empty((1, nc))     # the step writes row `row`
    p11, p12, p22 = cov0
    restarts = restart.shape[0] > 0
    masked = observed.shape[0] > 0
    value = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(chans.shape[0]):
        predict = i > 0
        if predict and restarts and restart[i]:
            for c in range(nc):
                mean[2 * c] = chans[i, c]
                mean[2 * c + 1] = mean0[2 * c + 1]
            p11, p12, p22 = cov0
            predict = False
        observe = not masked or observed[i]
        row = i if what & INNOVATIONS else 0
        p11, p12, p22, sv = step(mean, e, row, chans, i, p11, p12, p22, d[i], g[i], noise, predict, observe)
        if what & MOMENTS:
            moments[i, 0] = mean[0]
            moments[i, 1] = mean[1]
            covs[i, 0] = p11
            covs[i, 1] = p12
            covs[i, 2] = p22
        if not observe:
            continue
        if what & LOGLIK:
            value -= 0.5 * (log2pi + math.log(sv) + e[row, 0] * e[row, 0] / sv)
        if what & INNOVATIONS:
            variance[i] = sv
        if what & QUADRATIC:
            w = 1.0 / sv
            for c in range(nc):
                for c2 in range(nc):
                    quad[c, c2] += e[row, c] * e[row, c2] * w
            value += math.log(sv)
    return value


def _one_channel(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22, observed, what, moments, covs, innovation, variance,
                 fading):
    """:func:`_forward` on the one channel ``z`` (m,, contiguous) from the prior [s, k] and
    [p11, p12, p22]; ``innovation`` is (m,) or (0,); ``fading`` the memory of :func:`step` (0: none)."""
    return _forward(d, g, z.reshape((z.shape[0], 1)), np.array([s, k]), (p11, p12, p22), (r, qs, qk, qc, fading),
                    np.zeros(0, dtype=np.bool_), observed, what, moments, covs,
                    innovation.reshape((innovation.shape[0], 1)), variance, np.zeros((0, 0)))


def kalman_loglik(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22, fading):
    """Log-likelihood of the one channel z (n,) under the model of :mod:`limbstiff.statespace`
    (prediction-error decomposition), from the prior [s, k] and [p11, p12, p22], with the
    stiffness's fading memory ``fading`` per step (:func:`step`; 0 offline, the live model's
    when its noise levels are fitted)."""
    none = np.zeros(0)
    return _one_channel(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22, np.zeros(0, dtype=np.bool_), LOGLIK,
                        np.zeros((0, 2)), np.zeros((0, 3)), none, none, fading)


def kalman_filter(d, g, z, observed, r, qs, qk, qc, s, k, p11, p12, p22, with_loglik):
    """The forward pass keeping the filtered moments (the predicted ones are recomputed by
    :func:`rts_smoother`, which halves the memory written per step).

    Where ``observed[i]`` is False the measurement is treated as missing: the state is only
    predicted there (held-out prediction).

    Returns
    -------
    mean : ndarray, shape (n, 2)
        Filtered [s, σ].
    cov : ndarray, shape (n, 3)
        Filtered [p11, p12, p22].
    loglik : float
        Log-likelihood of the observed steps (0 unless ``with_loglik``: the logarithm is most
        of a step's cost).
    """
    n = z.shape[0]
    mean = np.empty((n, 2))
    cov = np.empty((n, 3))
    what = MOMENTS | LOGLIK if with_loglik else MOMENTS
    none = np.zeros(0)
    loglik = _one_channel(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22, observed, what, mean, cov, none, none, 0.0)
    return mean, cov, loglik


def kalman_innovations(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22):
    """The forward pass returning the one-step prediction errors e = z − ŝ⁻ and their
    variances S (each shape (n,)): white, of variance S, when the model is right."""
    n = z.shape[0]
    innovation = np.empty(n)
    variance = np.empty(n)
    _one_channel(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22, np.zeros(0, dtype=np.bool_), INNOVATIONS,
                 np.zeros((0, 2)), np.zeros((0, 3)), innovation, variance, 0.0)
    return innovation, variance


def rts_smoother(d, g, mean, cov, qs, qk, qc):
    """Rauch–Tung–Striebel pass, in place: ``mean`` (n, 2) and ``cov`` (n, 3) hold the filtered
    moments of :func:`kalman_filter` on entry and the smoothed ones on return.

    The predicted moments of step i + 1 are recomputed from the filtered ones of step i by the
    same expressions as the filter's, so the result equals a pass over stored ones exactly.
    """
    n = mean.shape[0]
    s1 = mean[n - 1, 0]
    k1 = mean[n - 1, 1]
    a11 = cov[n - 1, 0]
    a12 = cov[n - 1, 1]
    a22 = cov[n - 1, 2]
    for i in range(n - 2, -1, -1):
        di = d[i + 1]
        f11 = cov[i, 0]
        f12 = cov[i, 1]
        f22 = cov[i, 2]
        fs = mean[i, 0]
        fk = mean[i, 1]
        q11, q12, q22 = _predict(f11, f12, f22, di, g[i + 1], qs, qk, qc)
        # gain C = P_f·Fᵀ·(P⁻)⁻¹ with F = [[1, d], [0, 1]]
        b11 = f11 + di * f12
        b12 = f12
        b21 = f12 + di * f22
        b22 = f22
        det = q11 * q22 - q12 * q12
        i11 = q22 / det
        i12 = -q12 / det
        i22 = q11 / det
        c11 = b11 * i11 + b12 * i12
        c12 = b11 * i12 + b12 * i22
        c21 = b21 * i11 + b22 * i12
        c22 = b21 * i12 + b22 * i22
        e1 = s1 - (fs + fk * di)
        e2 = k1 - fk
        s1 = fs + c11 * e1 + c12 * e2
        k1 = fk + c21 * e1 + c22 * e2
        m11 = a11 - q11
        m12 = a12 - q12
        m22 = a22 - q22
        # P_s = P_f + C·(P_s⁺ − P⁻)·Cᵀ
        t11 = c11 * m11 + c12 * m12
        t12 = c11 * m12 + c12 * m22
        t21 = c21 * m11 + c22 * m12
        t22 = c21 * m12 + c22 * m22
        a11 = f11 + t11 * c11 + t12 * c12
        a12 = f12 + t11 * c21 + t12 * c22
        a22 = f22 + t21 * c21 + t22 * c22
        mean[i, 0] = s1
        mean[i, 1] = k1
        cov[i, 0] = a11
        cov[i, 1] = a12
        cov[i, 2] = a22
    return mean, cov


def _prior(chans, slopes):
    """[s, σ] of each channel at the first step: its first value (chans (m, c)) and its slope."""
    mean0 = np.empty(2 * chans.shape[1])
    for c in range(chans.shape[1]):
        mean0[2 * c] = chans[0, c]
        mean0[2 * c + 1] = slopes[c]
    return mean0


def kalman_channel_innovations(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart):
    """One forward pass of the model over several measurement channels at once.

    The covariance recursion does not depend on the data, so every channel's innovations share
    their variance S[k], and for z = Σ_c w_c·chans[c] the innovations are Σ_c w_c·e_c[k] (the
    filter is linear in the data). Arguments as :func:`kalman_quadratic`; ``chans`` (c, n) may be
    the transpose of a C-ordered (n, c) array, each step's channels then contiguous (many
    channels, a curve's weights, run several times faster so), and the innovations have its layout.

    Returns
    -------
    innovations : ndarray, shape (c, n)
        Each channel's one-step prediction errors.
    variance : ndarray, shape (n,)
        Their common variance S.
    """
    rows = chans.T
    innovations = np.empty_like(chans)
    variance = np.empty(rows.shape[0])
    _forward(d, g, rows, _prior(rows, slopes), (p11, 0.0, p22), (r, qs, qk, qc, 0.0), restart,
             np.zeros(0, dtype=np.bool_), INNOVATIONS, np.zeros((0, 2)), np.zeros((0, 3)), innovations.T, variance,
             np.zeros((0, 0)))
    return innovations, variance


def kalman_quadratic(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart):
    """One forward pass of the model over several measurement channels at once, its likelihood
    as a quadratic form in their weights.

    The covariance recursion does not depend on the data, so the innovations of every channel
    share their variance S[k]. For z = Σ_c w_c·chans[c] (for example w = (1, −m, −b) on
    f, ÿ, ẏ) the log-likelihood is −½·(n·ln 2π + Σ ln S + wᵀ·A·w) with A[c, c'] = Σ e_c·e_c'/S.

    ``d``, ``g`` (n,) are the angle's increments and the spring's deflection, ``chans`` (c, n) the
    channels with ``slopes`` (c,) their initial σ (least-squares slopes on y), ``r, qs, qk, qc``
    the noise variances per step, ``p11``, ``p22`` the initial variances of s and σ, ``restart``
    (bool (n,)) where the state restarts (independent blocks of data). Returns Σ ln S and A (c, c).
    """
    per_step = np.empty((1, 4))
    per_step[0, 0] = r
    per_step[0, 1] = qs
    per_step[0, 2] = qk
    per_step[0, 3] = qc
    sums, quad = kalman_quadratic_many(d, g, chans, slopes, per_step, p11, p22, restart)
    return sums[0], quad[0]


def kalman_quadratic_many(d, g, chans, slopes, per_step, p11, p22, restart):
    """:func:`kalman_quadratic` for several noise levels in one call (an ensemble's walkers):
    each row of ``per_step`` (K, 4) holds (r, qs, qk, qc).

    Returns
    -------
    sum_log_s : ndarray, shape (K,)
    a : ndarray, shape (K, c, c)
    """
    rows = chans.T
    nk = per_step.shape[0]
    sums = np.zeros(nk)
    quad = np.zeros((nk, rows.shape[1], rows.shape[1]))
    mean0 = _prior(rows, slopes)
    observed = np.zeros(0, dtype=np.bool_)
    none = np.zeros(0)
    for j in range(nk):
        noise = (per_step[j, 0], per_step[j, 1], per_step[j, 2], per_step[j, 3], 0.0)
        sums[j] = _forward(d, g, rows, mean0, (p11, 0.0, p22), noise, restart, observed, QUADRATIC,
                           np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 0)), none, quad[j])
    return sums, quad


def marginal_two(sum_log_s, a, n):
    """The closed form of :func:`~limbstiff.statespace.linear.integrate_out` for two coefficients
    (m and b), for K quadratic forms ``a`` (K, 3, 3) at once.

    Returns
    -------
    loglik : ndarray, shape (K,)
        −inf where the form does not determine the coefficients.
    mean : ndarray, shape (K, 2)
    cov : ndarray, shape (K, 2, 2)
    """
    nk = a.shape[0]
    loglik = np.empty(nk)
    mean = np.full((nk, 2), np.nan)
    cov = np.full((nk, 2, 2), np.nan)
    log2pi = math.log(2.0 * math.pi)
    for j in range(nk):
        det = a[j, 1, 1] * a[j, 2, 2] - a[j, 1, 2] * a[j, 1, 2]
        if not det > 0.0:
            loglik[j] = -np.inf
            continue
        c11 = a[j, 2, 2] / det
        c12 = -a[j, 1, 2] / det
        c22 = a[j, 1, 1] / det
        m = c11 * a[j, 0, 1] + c12 * a[j, 0, 2]
        b = c12 * a[j, 0, 1] + c22 * a[j, 0, 2]
        q_min = a[j, 0, 0] - (a[j, 0, 1] * m + a[j, 0, 2] * b)
        loglik[j] = -0.5 * (n * log2pi + sum_log_s[j] + q_min) + log2pi - 0.5 * math.log(det)
        mean[j, 0] = m
        mean[j, 1] = b
        cov[j, 0, 0] = c11
        cov[j, 0, 1] = c12
        cov[j, 1, 0] = c12
        cov[j, 1, 1] = c22
    return loglik, mean, cov


def _compile():
    if os.environ.get("LIMBSTIFF_NO_JIT", "") not in ("", "0"):
        return False
    try:
        from numba import njit
    except ImportError:
        return False
    g = globals()
    # numba inlines these into their callers (its IR, not LLVM's): each variant of the pass then
    # runs with its flags constant, and the arrays the step takes cost no reference counting per
    # step (a compiled call per step made the pass 1.5–2× slower)
    for name in ("_predict", "_update", "step", "_forward", "_one_channel"):
        g[name] = njit(inline="always")(g[name])
    for name in ("_prior", "linear_recursion", "kalman_filter", "kalman_innovations",
                 "kalman_loglik", "rts_smoother", "kalman_channel_innovations", "kalman_quadratic_many",
                 "kalman_quadratic", "marginal_two"):
        g[name] = njit(cache=True, nogil=True)(g[name])
    return True


#: True when the kernels are compiled by numba.
COMPILED = _compile()
