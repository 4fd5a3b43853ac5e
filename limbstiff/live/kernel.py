"""The causal chain of the live estimate, one sample at a time: compiled with numba.

Per input sample: the angle y and torque f through the same causal Butterworth low-pass
(second-order sections, direct form II transposed as :func:`scipy.signal.sosfilt`), the last nine
filtered samples kept, ẏ and ÿ of the middle one by the eighth-order central differences of the
offline chain (:func:`limbstiff.signals.central_derivatives`) — so every channel is taken four
samples back, alike — and, every ``decimation``-th of those, one step of the state-space model of
:mod:`limbstiff.statespace` (the offline filter's own :func:`~limbstiff.statespace.kernels.step`,
with the stiffness's fading memory) on three measurement channels f, ÿ and ẏ through the same
gains. The filter's mean is linear in the channel, so the stiffness for any (m, b) is
σ̂_f − m·σ̂_ÿ − b·σ̂_ẏ, and its derivatives with respect to m and b are the two other channels'
courses (the band carries m and b's covariance through them).

The state lives in three arrays the caller keeps between chunks (:class:`limbstiff.live.estimator.LiveEstimator`):

``fstate`` (float): the filter sections' states (2 signals × sections × 2), then the nine-sample
rings of filtered y and f, the deflection's ring of step angles, and the Kalman part
(:data:`KALMAN` names its slots). ``istate`` (int): :data:`SEEN`, :data:`RING_POS`,
:data:`PHASE`, :data:`DEFL_POS`, :data:`DEFL_COUNT`, :data:`STEPS`.
"""

from __future__ import annotations

import math

import numpy as np

from ..signals import CENTRAL_FIRST
from ..statespace import kernels

#: Slots of ``istate``: samples seen, ring position, samples to the next step, deflection ring
#: position and fill, model steps taken.
SEEN, RING_POS, PHASE, DEFL_POS, DEFL_COUNT, STEPS = range(6)
#: The Kalman part of ``fstate``: the three channels' [s, σ], the shared covariance, the last
#: step's angle, the last step's σ of each channel and p22 (for the half-step alignment of
#: :func:`~limbstiff.statespace.smoother.at_steps`), the deflection ring's sum, and the held output.
KALMAN = ("s_f", "k_f", "s_a", "k_a", "s_v", "k_v", "p11", "p12", "p22", "y_prev",
          "prev_f", "prev_a", "prev_v", "prev_p22", "defl_sum", "out_f", "out_a", "out_v", "out_var")
#: Columns of the kernel's output, one row per input sample: the stiffness for the given m and b
#: (σ̂_f − m·σ̂_ÿ − b·σ̂_ẏ, aligned to the step's middle), its band, whether the data inform it (1/0)
#: and the state's variance — held between steps, NaN before the first — then at the steps only
#: (NaN elsewhere) z's innovation e, its variance S, z = f − m·ÿ − b·ẏ itself, the angle and the
#: deflection (what :func:`limbstiff.live.identify.identify_live` fits the noise levels on).
OUT = ("stiffness", "lo", "hi", "observable", "var", "e", "s_var", "z", "y", "g")
#: ``mech``: m, b, their covariance (c_mm, c_mb, c_bb), the band's normal quantile, and the largest
#: state variance still informed (inf: every sample).
MECH = ("m", "b", "c_mm", "c_mb", "c_bb", "quantile", "informed_var")
#: Samples of the offline chain's central-difference stencils (:data:`limbstiff.signals.CENTRAL_FIRST`).
STENCIL = len(CENTRAL_FIRST)


def state_size(sections: int, window: int) -> int:
    """Length of ``fstate`` for ``sections`` filter sections and a deflection ring of ``window`` steps."""
    return 4 * sections + 2 * STENCIL + window + len(KALMAN)


def _sosfilt_one(x, sos, st, base):
    """One sample through the sections (direct form II transposed); states at st[base + 2·j]."""
    for j in range(sos.shape[0]):
        z0 = st[base + 2 * j]
        z1 = st[base + 2 * j + 1]
        out = sos[j, 0] * x + z0
        st[base + 2 * j] = sos[j, 1] * x - sos[j, 4] * out + z1
        st[base + 2 * j + 1] = sos[j, 2] * x - sos[j, 5] * out
        x = out
    return x


def _stencil(st, ring, pos, kernel):
    """Σ kernel[j]·x[newest − 8 + j] over the ring starting at ``ring`` (oldest at ``pos``)."""
    acc = 0.0
    for j in range(STENCIL):
        acc += kernel[j] * st[ring + (pos + j) % STENCIL]
    return acc


def _kalman_step(st, kal, y, work, g, per_step, first):
    """One model step (:func:`~limbstiff.statespace.kernels.step`) on the three channels of
    ``work``'s row 0 (f, ÿ, ẏ), their innovations written to its row 1; returns their variance S."""
    mean = st[kal:kal + 6]
    if first:
        for c in range(3):
            mean[2 * c] = work[0, c]
            mean[2 * c + 1] = 0.0
    noise = (per_step[0], per_step[1], per_step[2], per_step[3], per_step[4])
    p11, p12, p22, sv = kernels.step(mean, work, 1, work, 0, st[kal + 6], st[kal + 7], st[kal + 8], y - st[kal + 9], g,
                                     noise, not first, True)
    st[kal + 6], st[kal + 7], st[kal + 8], st[kal + 9] = p11, p12, p22, y
    return sv


def _combine(st, kal, mech, out, i):
    """Row i's stiffness, band and informed flag from the held channel courses, for m and b."""
    ka, kv, var = st[kal + 16], st[kal + 17], st[kal + 18]
    k = st[kal + 15] - mech[0] * ka - mech[1] * kv
    spread = var + mech[2] * ka * ka + 2.0 * mech[3] * ka * kv + mech[4] * kv * kv
    half = mech[5] * math.sqrt(max(spread, 0.0))
    out[i, 0], out[i, 1], out[i, 2] = k, k - half, k + half
    out[i, 3] = 1.0 if var <= mech[6] else 0.0
    out[i, 4] = var


def _model_step(fstate, istate, ring_y, ring_f, defl, kal, pos, first_d, second_d, per_step, mech, window, work,
                out, i):
    """One model step at the ring's middle sample: derivatives, deflection, the Kalman step, the
    half-step alignment, and row i's step columns."""
    m, b = mech[0], mech[1]
    yc = fstate[ring_y + (pos + 4) % STENCIL]
    fc = fstate[ring_f + (pos + 4) % STENCIL]
    vc = _stencil(fstate, ring_y, pos, first_d)
    ac = _stencil(fstate, ring_y, pos, second_d)
    # the deflection: the step's angle less the trailing average of the last `window` steps (the
    # offline average is centred, two motion periods of future a causal chain does not have; the
    # live noise levels are fitted on this deflection, limbstiff.live.identify)
    dp = istate[DEFL_POS]
    if istate[DEFL_COUNT] == window:
        fstate[kal + 14] -= fstate[defl + dp]
    else:
        istate[DEFL_COUNT] += 1
    fstate[defl + dp] = yc
    fstate[kal + 14] += yc
    istate[DEFL_POS] = (dp + 1) % window
    g = yc - fstate[kal + 14] / istate[DEFL_COUNT]
    first = istate[STEPS] == 0
    work[0, 0], work[0, 1], work[0, 2] = fc, ac, vc
    sv = _kalman_step(fstate, kal, yc, work, g, per_step, first)
    ef, ea, ev = work[1, 0], work[1, 1], work[1, 2]
    for c in range(3):
        k_now = fstate[kal + 2 * c + 1]
        k_prev = k_now if first else fstate[kal + 10 + c]
        fstate[kal + 15 + c] = 0.5 * (k_prev + k_now)
        fstate[kal + 10 + c] = k_now
    p_now = fstate[kal + 8]
    p_prev = p_now if first else fstate[kal + 13]
    fstate[kal + 18] = 0.5 * (p_prev + p_now)
    fstate[kal + 13] = p_now
    istate[STEPS] += 1
    out[i, 5], out[i, 6], out[i, 7] = ef - m * ea - b * ev, sv, fc - m * ac - b * vc
    out[i, 8], out[i, 9] = yc, g


def causal_chunk(y, f, sos, fstate, istate, first_d, second_d, per_step, mech, decimation, window, out):
    """Run the causal chain over one chunk of samples, continuing from the state.

    Parameters
    ----------
    y, f : ndarray, shape (n,)
        Raw angle (rad, m) and torque (N·m, N) in SI units.
    sos : ndarray, shape (sections, 6)
        The low-pass (:func:`scipy.signal.butter` ``output="sos"``).
    fstate, istate : ndarray
        The chain's state (module docstring), updated in place; the filter's states must be set
        for the first sample (:func:`scipy.signal.sosfilt_zi` times it) before the first call.
    first_d, second_d : ndarray, shape (9,)
        The central-difference stencils divided by Ts and Ts².
    per_step : ndarray, shape (5,)
        (R, Q_s·Δt, Q_σ·Δt, Q_c·Δt) of :meth:`~limbstiff.statespace.noise.NoiseLevels.per_step`,
        then the stiffness's fading memory per step, 1/λ − 1 (λ = exp(−Δt/T), T the memory; 0 for
        none); ``fstate``'s p11 and p22 hold the initial covariance until the first step.
    mech : ndarray, shape (7,)
        :data:`MECH`.
    decimation : int
        Samples per model step.
    window : int
        Steps of the deflection's trailing average.
    out : ndarray, shape (n, 10)
        Written: the columns of :data:`OUT`.
    """
    sections = sos.shape[0]
    ring_y = 4 * sections
    ring_f = ring_y + STENCIL
    defl = ring_f + STENCIL
    kal = defl + window
    n = y.shape[0]
    work = np.empty((2, 3))
    for i in range(n):
        yf = _sosfilt_one(y[i], sos, fstate, 0)
        ff = _sosfilt_one(f[i], sos, fstate, 2 * sections)
        pos = istate[RING_POS]
        fstate[ring_y + pos] = yf
        fstate[ring_f + pos] = ff
        pos = (pos + 1) % STENCIL
        istate[RING_POS] = pos
        istate[SEEN] += 1
        for c in range(5, 10):
            out[i, c] = np.nan
        if istate[SEEN] >= STENCIL:
            if istate[PHASE] == 0:
                _model_step(fstate, istate, ring_y, ring_f, defl, kal, pos, first_d, second_d, per_step, mech,
                            window, work, out, i)
            istate[PHASE] = (istate[PHASE] + 1) % decimation
        if istate[STEPS] == 0:
            for c in range(5):
                out[i, c] = np.nan
        else:
            _combine(fstate, kal, mech, out, i)


def _compile():
    if not kernels.COMPILED:
        return False
    from numba import njit

    g = globals()
    for name in ("_sosfilt_one", "_stencil", "_kalman_step", "_combine", "_model_step", "causal_chunk"):
        g[name] = njit(cache=True, nogil=True)(g[name])
    return True


#: True when the chain is compiled by numba (as :data:`limbstiff.statespace.kernels.COMPILED`).
COMPILED = _compile()
