"""The live (causal) stiffness estimate: the analysis's Kalman model run forwards only, chunk by chunk.

:class:`LiveModel` is what the data must give first — the low-pass corner, the motion frequency,
the model's noise levels, m and b with their covariance — and :class:`LiveEstimator` runs the
causal chain of :mod:`limbstiff.live.kernel` with it on chunks of raw samples as they arrive,
returning the stiffness, its band and whether the data inform it (:class:`LiveOutput`). The
offline analysis smooths (its estimate at t uses the data after t too); this one cannot, so it
lags: the low-pass's group delay, four samples for the derivatives' stencil, and the filter's own
lag behind a stiffness that changes (measured in ``benchmarks/live.py``). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal, stats

from ..estimate.informed import BAND_WIDENING
from ..signals import CENTRAL_FIRST, CENTRAL_SECOND
from ..statespace.noise import NoiseLevels
from ..statespace.steps import DEFLECTION_PERIODS, kalman_decimation
from . import kernel

#: Order of the causal Butterworth low-pass: the offline chain's (:func:`limbstiff.signals.zero_phase_lowpass`),
#: run once instead of forwards and backwards.
LOWPASS_ORDER = 4


@dataclass(frozen=True)
class LiveModel:
    """What the live estimate needs from the data first (:func:`limbstiff.live.identify.identify_live`).

    Parameters
    ----------
    fs : float, Hz
        Sampling rate of the stream.
    corner_hz : float or None, Hz
        Low-pass corner (None: no low-pass, every sample a model step).
    motion_hz : float, Hz
        Typical motion frequency (the deflection's average spans :data:`DEFLECTION_PERIODS` periods).
    noise : NoiseLevels
        The model's noise levels (fitted on the causal chain's own steps).
    inertia, damping : float
        m (kg·m², kg) and b (N·m·s/rad, N·s/m); 0 for the direct variant.
    covariance : ndarray, shape (2, 2)
        Covariance of (m, b): carried into the band.
    initial_cov : (float, float)
        Diffuse prior variances of the elastic torque and of the stiffness at the first step.
    typical_variance : float or None, (N·m/rad)²
        The median state variance where the data informed the estimate: a sample whose variance is
        over :data:`~limbstiff.estimate.informed.BAND_WIDENING`² times it is not informed (as offline).
    ci_level : float
        Level of the band.
    identified_s : float, s
        Seconds of data the model was identified from.
    smoother_noise : NoiseLevels or None
        The noise levels the identification fitted on the zero-phase signals (the offline
        smoother's, for the ``hindsight`` check; None: fitted when needed).
    memory_s : float or None, s
        The stiffness's fading memory T: its variance grows by exp(Δt/T) per step on top of the
        model's walk, so that data older than T weigh less than e⁻¹ whatever the noise levels
        fitted so far (None: the model's walk alone).
    """

    fs: float
    corner_hz: float | None
    motion_hz: float
    noise: NoiseLevels
    inertia: float
    damping: float
    covariance: np.ndarray
    initial_cov: tuple
    typical_variance: float | None
    ci_level: float = 0.9
    identified_s: float = 0.0
    memory_s: float | None = None
    smoother_noise: NoiseLevels | None = None

    @property
    def decimation(self) -> int:
        """Samples per model step (:func:`~limbstiff.statespace.steps.kalman_decimation`)."""
        return kalman_decimation(1.0 / self.fs, self.corner_hz)

    @property
    def fading(self) -> float:
        """The stiffness's fading memory per model step, 1/λ − 1 with λ = exp(−Δt/T) (0 without a
        memory): what :func:`~limbstiff.statespace.kernels.step` adds to its variance."""
        return 0.0 if self.memory_s is None else float(np.expm1(self.decimation / self.fs / self.memory_s))

    @property
    def window(self) -> int:
        """Model steps of the deflection's trailing average."""
        step = self.decimation / self.fs
        return max(1, int(round(DEFLECTION_PERIODS / (self.motion_hz * step))))

    @property
    def sos(self) -> np.ndarray:
        """The causal low-pass's second-order sections (a unit pass-through without a corner)."""
        if self.corner_hz is None:
            return np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])
        return signal.butter(LOWPASS_ORDER, self.corner_hz, fs=self.fs, output="sos")

    @property
    def delay_samples(self) -> float:
        """Samples by which the chain's signals lag the input at low frequencies: the low-pass's
        group delay at 0 Hz plus the stencil's four."""
        if self.corner_hz is None:
            return 4.0
        _, delay = signal.group_delay(signal.sos2tf(self.sos), w=[1e-6], fs=self.fs)
        return float(delay[0]) + 4.0


@dataclass(frozen=True)
class LiveOutput:
    """The live estimate on one chunk, one value per input sample (views of one array, shape (n,) each).

    Parameters
    ----------
    rows : ndarray, shape (n, 10)
        The chain's rows (columns :data:`~limbstiff.live.kernel.OUT`).
    """

    rows: np.ndarray

    @property
    def stiffness(self) -> np.ndarray:
        """The causal estimate, N·m/rad (N/m); NaN before the first model step."""
        return self.rows[:, 0]

    @property
    def lo(self) -> np.ndarray:
        """Lower end of the band (the state's variance and m and b's covariance)."""
        return self.rows[:, 1]

    @property
    def hi(self) -> np.ndarray:
        """Upper end of the band."""
        return self.rows[:, 2]

    @property
    def observable(self) -> np.ndarray:
        """1.0 where the data inform the estimate (the band not :data:`BAND_WIDENING` times its typical width)."""
        return self.rows[:, 3]

    @property
    def steps(self) -> np.ndarray:
        """The rows that are model steps (bool, shape (n,))."""
        return np.isfinite(self.rows[:, 5])

    @property
    def innovation(self) -> np.ndarray:
        """z's one-step prediction error at the steps (NaN elsewhere), N·m (N)."""
        return self.rows[:, 5]

    @property
    def innovation_variance(self) -> np.ndarray:
        """Its variance S at the steps, (N·m)²."""
        return self.rows[:, 6]

    @property
    def measured(self) -> np.ndarray:
        """z = f − m·ÿ − b·ẏ at the steps, N·m (N)."""
        return self.rows[:, 7]


class LiveEstimator:
    """The causal chain with its state, fed chunk by chunk (:meth:`push`). Picklable: a worker
    process can run it over the record so far and hand it over.

    Parameters
    ----------
    model : LiveModel
    """

    def __init__(self, model: LiveModel):
        self.model = model
        self._sos = np.ascontiguousarray(model.sos)
        step = model.decimation / model.fs
        self._per_step = np.array([*model.noise.per_step(step), model.fading])
        self._first = CENTRAL_FIRST * model.fs            # the offline chain's stencils, over Ts and Ts²
        self._second = CENTRAL_SECOND * model.fs ** 2
        self._mech = _mech(model)
        self.reset()

    def reset(self) -> None:
        """Start again from the next sample (after a gap too long to bridge)."""
        m = self.model
        self.fstate = np.zeros(kernel.state_size(len(self._sos), m.window))
        self.istate = np.zeros(6, dtype=np.int64)
        kal = self.fstate.size - len(kernel.KALMAN)
        self.fstate[kal + 6], self.fstate[kal + 8] = m.initial_cov
        self._started = False

    @property
    def steps(self) -> int:
        """Model steps taken since the last reset."""
        return int(self.istate[kernel.STEPS])

    def retuned(self, model: LiveModel) -> None:
        """Go on with ``model``'s m, b, their covariance and typical variance (the chain's corner,
        noise levels and steps must be the same: the state is kept)."""
        def chain(m):
            return (m.fs, m.corner_hz, m.noise, m.decimation, m.window, m.memory_s)

        if chain(model) != chain(self.model):
            raise ValueError("retuned() keeps the chain: the corner, noise levels and steps must not change")
        self.model = model
        self._mech = _mech(model)

    def push(self, angle: np.ndarray, torque: np.ndarray) -> LiveOutput:
        """Run the chain over the next samples.

        Parameters
        ----------
        angle, torque : ndarray, shape (n,)
            Raw samples in SI units, in order, without gaps.

        Returns
        -------
        LiveOutput
        """
        y = np.ascontiguousarray(angle, dtype=float)
        f = np.ascontiguousarray(torque, dtype=float)
        if not self._started and len(y):
            zi = signal.sosfilt_zi(self._sos)
            self.fstate[:2 * zi.size] = np.concatenate([(zi * y[0]).ravel(), (zi * f[0]).ravel()])
            self._started = True
        out = np.empty((len(y), len(kernel.OUT)))
        kernel.causal_chunk(y, f, self._sos, self.fstate, self.istate, self._first, self._second, self._per_step,
                            self._mech, self.model.decimation, self.model.window, out)
        return LiveOutput(out)


def _mech(model: LiveModel) -> np.ndarray:
    c = np.asarray(model.covariance, dtype=float)
    limit = np.inf if model.typical_variance is None else BAND_WIDENING ** 2 * model.typical_variance
    return np.array([model.inertia, model.damping, c[0, 0], c[0, 1], c[1, 1],
                     stats.norm.ppf(0.5 + model.ci_level / 2), limit])
