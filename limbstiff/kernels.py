"""The sequential recursions of the estimators, compiled with numba when it is available.

Each kernel is written once, as a plain loop over numpy arrays that both CPython and numba
run. With numba installed the module exports the compiled versions (``cache=True``, so the
compilation of a few seconds happens once per installation); without it, or with the
environment variable ``LIMBSTIFF_NO_JIT=1``, the same source runs in CPython. The reference
(``<kernel>.py_func`` when compiled) is what the tests compare the compiled code against.

Kernels: the first-order linear recursion of the observer (alone, and fused with its
coefficients), the two-state Kalman filter
(log-likelihood only, or with its moments), the Rauch–Tung–Striebel smoother, and the
filter pass over several measurement channels whose likelihood is quadratic in their weights
(inertia and damping, :mod:`limbstiff.identify`).
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


def observer_pass(velocity, drive, gain_step, threshold, exact, initial):
    """Update law (7) in one loop: the coefficients of
    :func:`limbstiff.observer.recursion_coefficients` computed on the fly, then
    x[k] = a[k]·x[k−1] + c[k]. ``gain_step`` is α·Ts; returns σ̂, shape (n,)."""
    n = velocity.shape[0]
    out = np.empty(n)
    x = initial
    for k in range(n):
        v = velocity[k]
        speed = abs(v)
        if speed > threshold:
            g = gain_step * speed
            sign = 1.0 if v > 0 else -1.0
            if exact:
                x = math.exp(-g) * x - math.expm1(-g) / speed * sign * drive[k]
            else:
                x = (1.0 - g) * x + gain_step * sign * drive[k]
        out[k] = x
    return out


def kalman_loglik(d, z, r, qs, qk, s, k, p11, p12, p22):
    """Log-likelihood of the model of :mod:`limbstiff.smoothing` (the filter pass of
    :func:`kalman_moments`, moments discarded)."""
    return kalman_moments(d, z, r, qs, qk, s, k, p11, p12, p22)[4]


def kalman_moments(d, z, r, qs, qk, s, k, p11, p12, p22):
    """Filter pass keeping the filtered and predicted moments.

    Returns
    -------
    fm, fc, pm, pc : ndarray, shapes (n, 2), (n, 3), (n, 2), (n, 3)
        Filtered mean [s, σ], covariance [p11, p12, p22], and the same predicted.
    loglik : float
    """
    n = z.shape[0]
    fm = np.empty((n, 2))
    fc = np.empty((n, 3))
    pm = np.empty((n, 2))
    pc = np.empty((n, 3))
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(n):
        if i > 0:
            di = d[i]
            s = s + k * di
            p11 = p11 + 2.0 * di * p12 + di * di * p22 + qs
            p12 = p12 + di * p22
            p22 = p22 + qk
        pm[i, 0] = s
        pm[i, 1] = k
        pc[i, 0] = p11
        pc[i, 1] = p12
        pc[i, 2] = p22
        sv = p11 + r
        e = z[i] - s
        g1 = p11 / sv
        g2 = p12 / sv
        s = s + g1 * e
        k = k + g2 * e
        p22 = p22 - g2 * p12
        p12 = p12 - g1 * p12
        p11 = p11 - g1 * p11
        loglik -= 0.5 * (log2pi + math.log(sv) + e * e / sv)
        fm[i, 0] = s
        fm[i, 1] = k
        fc[i, 0] = p11
        fc[i, 1] = p12
        fc[i, 2] = p22
    return fm, fc, pm, pc, loglik


def rts_smoother(d, fm, fc, pm, pc):
    """Rauch–Tung–Striebel pass; returns smoothed mean (n, 2) and covariance (n, 3)."""
    n = fm.shape[0]
    sm = np.empty((n, 2))
    sc = np.empty((n, 3))
    s1 = fm[n - 1, 0]
    k1 = fm[n - 1, 1]
    a11 = fc[n - 1, 0]
    a12 = fc[n - 1, 1]
    a22 = fc[n - 1, 2]
    sm[n - 1, 0] = s1
    sm[n - 1, 1] = k1
    sc[n - 1, 0] = a11
    sc[n - 1, 1] = a12
    sc[n - 1, 2] = a22
    for i in range(n - 2, -1, -1):
        di = d[i + 1]
        f11 = fc[i, 0]
        f12 = fc[i, 1]
        f22 = fc[i, 2]
        q11 = pc[i + 1, 0]
        q12 = pc[i + 1, 1]
        q22 = pc[i + 1, 2]
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
        e1 = s1 - pm[i + 1, 0]
        e2 = k1 - pm[i + 1, 1]
        s1 = fm[i, 0] + c11 * e1 + c12 * e2
        k1 = fm[i, 1] + c21 * e1 + c22 * e2
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
        sm[i, 0] = s1
        sm[i, 1] = k1
        sc[i, 0] = a11
        sc[i, 1] = a12
        sc[i, 2] = a22
    return sm, sc


def kalman_quadratic(d, chans, slopes, r, qs, qk, p11, p22, restart):
    """One filter pass of the two-state model over several measurement channels at once.

    The covariance recursion does not depend on the data, so the innovations of every channel
    share their variance S[k]. For z = Σ_c w_c·chans[c] (for example w = (1, −m, −b) on
    f, ÿ, ẏ) the log-likelihood is −½·(n·ln 2π + Σ ln S + wᵀ·A·w) with A[c, c'] = Σ e_c·e_c'/S.

    Parameters
    ----------
    d : (n,) increments of y
    chans : (c, n) measurement channels
    slopes : (c,) initial σ of each channel (its least-squares slope on y)
    r, qs, qk : noise variances per step
    p11, p22 : initial variances of s and σ
    restart : (n,) bool; where True the state restarts (independent blocks of data)

    Returns
    -------
    sum_log_s : float
    a : ndarray, shape (c, c)
    """
    nc = chans.shape[0]
    n = chans.shape[1]
    s = np.empty(nc)
    sig = np.empty(nc)
    e = np.empty(nc)
    for c in range(nc):
        s[c] = chans[c, 0]
        sig[c] = slopes[c]
    a = np.zeros((nc, nc))
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
            a11 = a11 + 2.0 * di * a12 + di * di * a22 + qs
            a12 = a12 + di * a22
            a22 = a22 + qk
        sv = a11 + r
        g1 = a11 / sv
        g2 = a12 / sv
        for c in range(nc):
            e[c] = chans[c, i] - s[c]
            s[c] += g1 * e[c]
            sig[c] += g2 * e[c]
        for c in range(nc):
            for c2 in range(nc):
                a[c, c2] += e[c] * e[c2] / sv
        a22 = a22 - g2 * a12
        a12 = a12 - g1 * a12
        a11 = a11 - g1 * a11
        sum_log_s += math.log(sv)
    return sum_log_s, a


def marginal_loglik(d, chans, slopes, r, qs, qk, p11, p22, restart):
    """Log-likelihood of the noise levels with the weights of channels 1 and 2 (−m, −b)
    integrated out under a flat prior, and their Gaussian posterior (see
    :func:`kalman_quadratic`). Returns (loglik, m, b, var_m, cov_mb, var_b); loglik is −inf
    when the data do not determine m and b."""
    sls, a = kalman_quadratic(d, chans, slopes, r, qs, qk, p11, p22, restart)
    h1 = a[0, 1]
    h2 = a[0, 2]
    det = a[1, 1] * a[2, 2] - a[1, 2] * a[1, 2]
    if not det > 0.0:
        return -np.inf, np.nan, np.nan, np.nan, np.nan, np.nan
    c11 = a[2, 2] / det
    c12 = -a[1, 2] / det
    c22 = a[1, 1] / det
    m = c11 * h1 + c12 * h2
    b = c12 * h1 + c22 * h2
    q_min = a[0, 0] - (h1 * m + h2 * b)
    n = chans.shape[1]
    loglik = -0.5 * (n * math.log(2.0 * math.pi) + sls + q_min) + math.log(2.0 * math.pi) - 0.5 * math.log(det)
    return loglik, m, b, c11, c12, c22


def _compile():
    if os.environ.get("LIMBSTIFF_NO_JIT", "") not in ("", "0"):
        return False
    try:
        from numba import njit
    except ImportError:
        return False
    g = globals()
    # callees first, so that the compiled callers call compiled code
    for name in ("linear_recursion", "observer_pass", "kalman_moments", "kalman_loglik", "rts_smoother", "kalman_quadratic",
                 "marginal_loglik"):
        g[name] = njit(cache=True, nogil=True)(g[name])
    return True


#: True when the kernels are compiled by numba.
COMPILED = _compile()
