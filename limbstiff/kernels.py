"""The sequential recursions of the estimators, compiled with numba when it is available.

Each kernel is written once, as a plain loop over numpy arrays that both CPython and numba
run. With numba installed the module exports the compiled versions (``cache=True``, so the
compilation of a few seconds happens once per installation); without it, or with the
environment variable ``LIMBSTIFF_NO_JIT=1``, the same source runs in CPython. The reference
(``<kernel>.py_func`` when compiled) is what the tests compare the compiled code against.

Kernels: the first-order linear recursion of the observer, the two-state Kalman filter
(log-likelihood only, or with its moments), the Rauch–Tung–Striebel smoother, and the
four-state filter that carries inertia and damping as constant states (:mod:`limbstiff.smoothing`).
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


def kalman_loglik(d, z, r, qs, qk, s, k, p11, p12, p22):
    """Log-likelihood of the model of :mod:`limbstiff.smoothing` (filter pass, no storage)."""
    n = z.shape[0]
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(n):
        if i > 0:
            di = d[i]
            s = s + k * di
            p11 = p11 + 2.0 * di * p12 + di * di * p22 + qs
            p12 = p12 + di * p22
            p22 = p22 + qk
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
    return loglik


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


def kalman_mechanics(d, f, acc, vel, r, qs, qk, x0, p0):
    """Filter with inertia and damping as constant states: x = [s, σ, m, b].

    Measurement f[k] = s + m·ÿ[k] + b·ẏ[k] + v. Returns the log-likelihood (the marginal
    likelihood of the noise levels, m and b integrated over their Gaussian prior x0, p0) and
    the final filtered mean (4,) and covariance (4, 4) — the posterior of the constant m, b.
    """
    n = f.shape[0]
    x = x0.copy()
    p = p0.copy()
    ph = np.empty(4)
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for i in range(n):
        if i > 0:
            di = d[i]
            x[0] += x[1] * di
            # P ← F·P·Fᵀ + Q with F = I + d·e0·e1ᵀ
            for j in range(4):
                p[0, j] += di * p[1, j]
            for j in range(4):
                p[j, 0] += di * p[j, 1]
            p[0, 0] += qs
            p[1, 1] += qk
        h2 = acc[i]
        h3 = vel[i]
        for j in range(4):
            ph[j] = p[j, 0] + p[j, 2] * h2 + p[j, 3] * h3
        sv = ph[0] + ph[2] * h2 + ph[3] * h3 + r
        e = f[i] - (x[0] + x[2] * h2 + x[3] * h3)
        for j in range(4):
            x[j] += ph[j] * e / sv
        for j in range(4):
            for l in range(4):
                p[j, l] -= ph[j] * ph[l] / sv
        loglik -= 0.5 * (log2pi + math.log(sv) + e * e / sv)
    return loglik, x, p


def _compile():
    if os.environ.get("LIMBSTIFF_NO_JIT", "") not in ("", "0"):
        return False
    try:
        from numba import njit
    except ImportError:
        return False
    g = globals()
    for name in ("linear_recursion", "kalman_loglik", "kalman_moments", "rts_smoother", "kalman_mechanics"):
        g[name] = njit(cache=True, nogil=True)(g[name])
    return True


#: True when the kernels are compiled by numba.
COMPILED = _compile()
