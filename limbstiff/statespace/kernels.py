"""The sequential recursions of the estimators, compiled with numba when it is available.

Each kernel is written once, as a plain loop over numpy arrays that both CPython and numba
run. With numba installed the module exports the compiled versions (``cache=True``, so the
compilation of a few seconds happens once per installation); without it, or with the
environment variable ``LIMBSTIFF_NO_JIT=1``, the same source runs in CPython. The reference
(``<kernel>.py_func`` when compiled) is what the tests compare the compiled code against.

Kernels: the first-order linear recursion of the observer; the two-state Kalman model's covariance step, written once (:func:`_predict`,
:func:`_update`) and used by the filter (log-likelihood only, or with its moments), the
Rauch–Tung–Striebel smoother (in place) and the filter pass over several measurement channels
whose likelihood is quadratic in their weights (any linear coefficients,
:mod:`limbstiff.statespace.linear`).
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


def _advance(i, d, g, qs, qk, qc, s, k, p11, p12, p22):
    """The state [s, σ] and its covariance carried to step i (unchanged at the first step)."""
    if i > 0:
        s = s + k * d[i]
        p11, p12, p22 = _predict(p11, p12, p22, d[i], g[i], qs, qk, qc)
    return s, k, p11, p12, p22


def _observe(zi, r, s, k, p11, p12, p22):
    """The state updated with measurement ``zi``; also the innovation e and its variance S."""
    sv, g1, g2, p11, p12, p22 = _update(p11, p12, p22, r)
    e = zi - s
    return s + g1 * e, k + g2 * e, p11, p12, p22, e, sv


def kalman_loglik(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22):
    """Log-likelihood of the model of :mod:`limbstiff.statespace` (prediction-error
    decomposition); the filter pass of :func:`kalman_filter` keeping no moments."""
    n = z.shape[0]
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(n):
        s, k, p11, p12, p22 = _advance(i, d, g, qs, qk, qc, s, k, p11, p12, p22)
        s, k, p11, p12, p22, e, sv = _observe(z[i], r, s, k, p11, p12, p22)
        loglik -= 0.5 * (log2pi + math.log(sv) + e * e / sv)
    return loglik


def kalman_filter(d, g, z, observed, r, qs, qk, qc, s, k, p11, p12, p22, with_loglik):
    """Filter pass keeping the filtered moments (the predicted ones are recomputed by
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
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(n):
        s, k, p11, p12, p22 = _advance(i, d, g, qs, qk, qc, s, k, p11, p12, p22)
        if observed[i]:
            s, k, p11, p12, p22, e, sv = _observe(z[i], r, s, k, p11, p12, p22)
            if with_loglik:
                loglik -= 0.5 * (log2pi + math.log(sv) + e * e / sv)
        mean[i, 0] = s
        mean[i, 1] = k
        cov[i, 0] = p11
        cov[i, 1] = p12
        cov[i, 2] = p22
    return mean, cov, loglik


def kalman_innovations(d, g, z, r, qs, qk, qc, s, k, p11, p12, p22):
    """Filter pass returning the one-step prediction errors e = z − ŝ⁻ and their variances S
    (each shape (n,)): white, of variance S, when the model is right."""
    n = z.shape[0]
    innovation = np.empty(n)
    variance = np.empty(n)
    for i in range(n):
        s, k, p11, p12, p22 = _advance(i, d, g, qs, qk, qc, s, k, p11, p12, p22)
        s, k, p11, p12, p22, e, sv = _observe(z[i], r, s, k, p11, p12, p22)
        innovation[i] = e
        variance[i] = sv
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


def kalman_channel_innovations(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart):
    """One filter pass of the two-state model over several measurement channels at once.

    The covariance recursion does not depend on the data, so every channel's innovations share
    their variance S[k], and for z = Σ_c w_c·chans[c] the innovations are Σ_c w_c·e_c[k] (the
    filter is linear in the data). Arguments as :func:`kalman_quadratic`.

    Returns
    -------
    innovations : ndarray, shape (c, n)
        Each channel's one-step prediction errors.
    variance : ndarray, shape (n,)
        Their common variance S.
    """
    nc = chans.shape[0]
    n = chans.shape[1]
    s = np.empty(nc)
    sig = np.empty(nc)
    for c in range(nc):
        s[c] = chans[c, 0]
        sig[c] = slopes[c]
    innovations = np.empty((nc, n))
    variance = np.empty(n)
    a11 = p11
    a12 = 0.0
    a22 = p22
    for i in range(n):
        if i > 0 and restart[i]:
            for c in range(nc):
                s[c] = chans[c, i]
                sig[c] = slopes[c]
            a11 = p11
            a12 = 0.0
            a22 = p22
        elif i > 0:
            di = d[i]
            for c in range(nc):
                s[c] += sig[c] * di
            a11, a12, a22 = _predict(a11, a12, a22, di, g[i], qs, qk, qc)
        sv, g1, g2, a11, a12, a22 = _update(a11, a12, a22, r)
        for c in range(nc):
            e = chans[c, i] - s[c]
            innovations[c, i] = e
            s[c] += g1 * e
            sig[c] += g2 * e
        variance[i] = sv
    return innovations, variance


def kalman_row_innovations(d, g, chans_t, slopes, r, qs, qk, qc, p11, p22, restart):
    """:func:`kalman_channel_innovations` with the channels as columns: ``chans_t`` (n, c) and
    the innovations (n, c), each step's channels contiguous — several times faster for many
    channels (a curve's weights), whose loop over channels the step's row keeps in cache. The loop
    is written twice on purpose: for the 3–4 channels of m, b and an effect, the transposed copy
    this layout needs made the likelihood 13 % slower (0.63 against 0.56 ms on 6000 steps).
    """
    n, nc = chans_t.shape
    s = np.empty(nc)
    sig = np.empty(nc)
    for c in range(nc):
        s[c] = chans_t[0, c]
        sig[c] = slopes[c]
    innovations = np.empty((n, nc))
    variance = np.empty(n)
    a11 = p11
    a12 = 0.0
    a22 = p22
    for i in range(n):
        if i > 0 and restart[i]:
            for c in range(nc):
                s[c] = chans_t[i, c]
                sig[c] = slopes[c]
            a11 = p11
            a12 = 0.0
            a22 = p22
        elif i > 0:
            di = d[i]
            for c in range(nc):
                s[c] += sig[c] * di
            a11, a12, a22 = _predict(a11, a12, a22, di, g[i], qs, qk, qc)
        sv, g1, g2, a11, a12, a22 = _update(a11, a12, a22, r)
        for c in range(nc):
            e = chans_t[i, c] - s[c]
            innovations[i, c] = e
            s[c] += g1 * e
            sig[c] += g2 * e
        variance[i] = sv
    return innovations, variance


def kalman_quadratic(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart):
    """One filter pass of the two-state model over several measurement channels at once.

    The covariance recursion does not depend on the data, so the innovations of every channel
    share their variance S[k]. For z = Σ_c w_c·chans[c] (for example w = (1, −m, −b) on
    f, ÿ, ẏ) the log-likelihood is −½·(n·ln 2π + Σ ln S + wᵀ·A·w) with A[c, c'] = Σ e_c·e_c'/S.

    Parameters
    ----------
    d : (n,) increments of y
    g : (n,) deflection of the spring at each step (:func:`limbstiff.statespace.steps.deflection`)
    chans : (c, n) measurement channels
    slopes : (c,) initial σ of each channel (its least-squares slope on y)
    r, qs, qk, qc : noise variances per step
    p11, p22 : initial variances of s and σ
    restart : (n,) bool; where True the state restarts (independent blocks of data)

    Returns
    -------
    sum_log_s : float
    a : ndarray, shape (c, c)
    """
    per_step = np.empty((1, 4))
    per_step[0, 0] = r
    per_step[0, 1] = qs
    per_step[0, 2] = qk
    per_step[0, 3] = qc
    sums, quad = kalman_quadratic_many(d, g, chans, slopes, per_step, p11, p22, restart)
    return sums[0], quad[0]


def kalman_quadratic_many(d, g, chans, slopes, per_step, p11, p22, restart):
    """:func:`kalman_quadratic` for several noise levels in one call (an ensemble's walkers).

    Each row of ``per_step`` (K, 4) holds (r, qs, qk, qc). The filter pass is fused with the sums,
    the innovations never stored: it repeats :func:`kalman_channel_innovations`'s loop on purpose
    (calling it per row and summing after was 15–50 % slower on the sampler's 3–4 channels).

    Returns
    -------
    sum_log_s : ndarray, shape (K,)
    a : ndarray, shape (K, c, c)
    """
    nc = chans.shape[0]
    n = chans.shape[1]
    nk = per_step.shape[0]
    sums = np.zeros(nk)
    quad = np.zeros((nk, nc, nc))
    s = np.empty(nc)
    sig = np.empty(nc)
    e = np.empty(nc)
    for j in range(nk):
        r = per_step[j, 0]
        qs = per_step[j, 1]
        qk = per_step[j, 2]
        qc = per_step[j, 3]
        for c in range(nc):
            s[c] = chans[c, 0]
            sig[c] = slopes[c]
        a11 = p11
        a12 = 0.0
        a22 = p22
        sum_log_s = 0.0
        for i in range(n):
            if i > 0 and restart[i]:
                for c in range(nc):
                    s[c] = chans[c, i]
                    sig[c] = slopes[c]
                a11 = p11
                a12 = 0.0
                a22 = p22
            elif i > 0:
                di = d[i]
                for c in range(nc):
                    s[c] += sig[c] * di
                a11, a12, a22 = _predict(a11, a12, a22, di, g[i], qs, qk, qc)
            sv, g1, g2, a11, a12, a22 = _update(a11, a12, a22, r)
            for c in range(nc):
                e[c] = chans[c, i] - s[c]
                s[c] += g1 * e[c]
                sig[c] += g2 * e[c]
            w = 1.0 / sv
            for c in range(nc):
                for c2 in range(nc):
                    quad[j, c, c2] += e[c] * e[c2] * w
            sum_log_s += math.log(sv)
        sums[j] = sum_log_s
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
    # callees first, so that the compiled callers call compiled code
    for name in ("_predict", "_update", "_advance", "_observe", "linear_recursion", "kalman_filter", "kalman_innovations", "kalman_loglik",
                 "rts_smoother", "kalman_channel_innovations", "kalman_row_innovations", "kalman_quadratic_many",
                 "kalman_quadratic", "marginal_two"):
        g[name] = njit(cache=True, nogil=True)(g[name])
    return True


#: True when the kernels are compiled by numba.
COMPILED = _compile()
