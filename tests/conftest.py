"""Shared fixtures: small synthetic trials written as files, and the real data's location."""

import os
import signal
from pathlib import Path

import numpy as np
import pytest

from limbstiff.files import write_trial
from limbstiff.trial import Trial

#: The five real ankle recordings, in the repository (GPL-2.0, outside the installed package).
REAL = Path(__file__).resolve().parents[1] / "data" / "reklab-ankle"
PROTOCOLS = Path(__file__).resolve().parents[1] / "protocols"

# The processes the tests start (``python -m limbstiff``, batch workers) import this tree, not a copy
# installed earlier: a tree edited after ``pip install .`` is tested as it is, and every process shares
# one numba cache (compiling the kernels costs each process ~10 s of CPU where none is cached).
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(Path(__file__).resolve().parents[1])] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])


def multisine_trial(name="synthetic", *, duration=8.0, fs=500.0, inertia=0.06, damping=0.45,
                    stiffness=(10.0, 20.0), seed=0) -> Trial:
    """A position-driven joint with exact torque: y a multisine, f = m·ÿ + b·ẏ + k(t)·y."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * fs)) / fs
    freqs = np.linspace(0.7, 6.0, 8)
    phases = rng.uniform(0, 2 * np.pi, freqs.size)
    w = 2 * np.pi * freqs[:, None]
    arg = w * t + phases[:, None]
    amp = 0.004
    y = amp * np.sin(arg).sum(0)
    v = amp * (w * np.cos(arg)).sum(0)
    a = -amp * (w ** 2 * np.sin(arg)).sum(0)
    k = np.linspace(*stiffness, t.size)
    return Trial(name=name, time=t, angle=y, torque=inertia * a + damping * v + k * y,
                 stiffness_true=k, metadata={"subject": "S01", "seed": str(seed)})


@pytest.fixture
def trial_file(tmp_path):
    """Write a synthetic trial CSV and return its path."""
    def make(name="synthetic", folder=None, **kw):
        folder = tmp_path if folder is None else folder
        path = Path(folder) / f"{name}.csv"
        write_trial(multisine_trial(name, **kw), path)
        return path
    return make


@pytest.fixture
def terminal_interrupts():
    """Ctrl-C reaches the processes the test starts as it does from a terminal. A shell's background
    job (``pytest … &``, ``nohup``) inherits SIGINT ignored, and every Python it starts then ignores
    Ctrl-C too; with a handler in this process instead, a started process gets the default (a
    handler is reset at exec, an ignored signal is not)."""
    before = signal.getsignal(signal.SIGINT)
    if before is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    if before is signal.SIG_IGN:
        signal.signal(signal.SIGINT, before)
