"""What a simulation knows and a recording does not: the true signals of a simulated trial.

:func:`limbstiff.simulate.plants.run` returns them as a :class:`TrueSignals` (the limb behind a
compliant coupling as a :class:`CoupledLimb`); :mod:`limbstiff.simulate` records them through a
device and keeps the stiffness as the trial's reference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CoupledLimb:
    """The limb of a set-up held through a compliant coupling (``ankle-coupled``), its device's
    motion imposed.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad
        θ_l at the sample times.
    velocity : ndarray, shape (n,), rad/s
    acceleration : ndarray, shape (n,), rad/s²
    jerk : ndarray, shape (n,), rad/s³
    coupling_torque : ndarray, shape (n,), N·m
        k_c·(θ_d − θ_l) + b_c·(θ̇_d − θ̇_l): what the coupling passes from the device to the limb.
    device_inertia : float, kg·m²
        I_d, of what lies between the coupling and the torque sensor.
    """

    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    coupling_torque: np.ndarray
    device_inertia: float


@dataclass(frozen=True)
class TrueSignals:
    """The noise-free signals of a simulated trial at its sample times (what :func:`run` returns).

    Units are a rotational joint's; a translational one has m for rad, N for N·m, kg for kg·m².

    Parameters
    ----------
    time : ndarray, shape (n,), s
        t = 0, 1/fs, …, duration.
    angle : ndarray, shape (n,), rad
        y, the joint's true angle (``ankle-coupled``: the device's; the limb's is in ``limb``).
    velocity : ndarray, shape (n,), rad/s
    acceleration : ndarray, shape (n,), rad/s²
    jerk : ndarray, shape (n,), rad/s³
    control : ndarray, shape (n,)
        u(t), the stiffness-regulating input (activation, rest length, stiffness…; the unit of
        the scenario's law).
    elastic_torque : ndarray, shape (n,), N·m
        s(y, u).
    stiffness : ndarray, shape (n,), N·m/rad
        σ = ∂s/∂y.
    generalized_damping : ndarray, shape (n,), N·m·s/rad
        ∂d/∂ẏ.
    damping_torque : ndarray, shape (n,), N·m
        d(ẏ).
    effect_torque : ndarray, shape (n,), N·m
        e, the unmodelled effect's torque (zeros without a dynamics effect).
    external_torque : ndarray, shape (n,), N·m
        τ_ext applied to the joint, before the sign of a reaction-torque sensor, measurement
        effects and noise.
    unrecorded_angle : ndarray, shape (n,), rad
        The part of ``angle`` the angle channel does not record (zeros unless the set-up records
        the angle about a moving operating point).
    inertia : float, kg·m²
        The true m.
    internal_step : float, s
        The RK4 step (0 for a position drive).
    delay : float, s
        The delay of a delayed effect as used (rounded to whole internal steps; 0 without one).
    limb : CoupledLimb or None
        The limb behind a compliant coupling (None for a set-up of one body).
    """

    time: np.ndarray
    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    control: np.ndarray
    elastic_torque: np.ndarray
    stiffness: np.ndarray
    generalized_damping: np.ndarray
    damping_torque: np.ndarray
    effect_torque: np.ndarray
    external_torque: np.ndarray
    unrecorded_angle: np.ndarray
    inertia: float
    internal_step: float
    delay: float
    limb: CoupledLimb | None = None
