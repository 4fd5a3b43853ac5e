"""What every generator returns, and the writer of limbstiff's standard CSV (numpy only).

A generated trial is a :class:`GeneratedTrial`: the recorded channels (angle, torque on a
uniform 1 kHz time base), the TRUE intrinsic stiffness at every sample, the exact noise-free
kinematics and torque parts in ``truth``, and the settings in ``params``. Ensembles add the
cycle ``marker``, the ``phase`` of every sample and the true stiffness by phase.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Column headers of limbstiff's standard CSV (``limbstiff/files/trial_csv.py``).
HEADERS = {"time": "time_s", "angle": "angle_rad", "torque": "torque_Nm",
           "stiffness_true": "stiffness_true_Nm_per_rad", "marker": "marker"}
#: Phase bins of the true stiffness by phase, by default (equal widths over [0, 1)).
N_PHASE_BINS = 50


@dataclass(frozen=True)
class GeneratedTrial:
    """One simulated trial and its ground truth.

    Parameters
    ----------
    name : str
        File stem when written.
    time : ndarray, shape (n,), s
        Uniform sample times from 0.
    angle : ndarray, shape (n,), rad
        Recorded joint angle (encoder-quantised).
    torque : ndarray, shape (n,), N·m
        Recorded torque applied TO the joint, positive towards +angle (with sensor noise).
    stiffness_true : ndarray, shape (n,), N·m/rad
        True intrinsic (incremental) stiffness at each sample; reflex torque is not part of it.
    metadata : dict of str to str
        Written as ``# key: value`` lines.
    truth : dict of str to ndarray
        Exact, noise-free channels at the samples (``theta``, ``velocity``, ``acceleration``,
        ``reflex`` …, see each generator).
    params : dict
        Every setting and every random draw that matters (JSON-serialisable).
    marker : ndarray, shape (n,), or None
        1 for the first 10 ms of every cycle (ensembles), else None.
    phase : ndarray, shape (n,), or None
        Phase in [0, 1) inside the recorded whole cycles, NaN outside (ensembles).
    truth_grid, truth_curve : ndarray or None
        True stiffness K(phase) on a fine phase grid over [0, 1] (ensembles).
    """

    name: str
    time: np.ndarray
    angle: np.ndarray
    torque: np.ndarray
    stiffness_true: np.ndarray
    metadata: dict = field(default_factory=dict)
    truth: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    marker: np.ndarray | None = None
    phase: np.ndarray | None = None
    truth_grid: np.ndarray | None = None
    truth_curve: np.ndarray | None = None

    def truth_by_phase(self, n_bins: int = N_PHASE_BINS) -> np.ndarray | None:
        """True stiffness by phase: the mean of K(phase) over each of ``n_bins`` equal bins
        (bin j covers [j/n, (j+1)/n)), N·m/rad; None for a trial without cycles."""
        if self.truth_curve is None:
            return None
        return bin_means(self.truth_grid, self.truth_curve, n_bins)


def bin_means(grid: np.ndarray, curve: np.ndarray, n_bins: int = N_PHASE_BINS) -> np.ndarray:
    """Mean of a periodic curve over each of ``n_bins`` equal phase bins.

    Parameters
    ----------
    grid : ndarray, shape (m,)
        Phase in [0, 1], uniformly spaced, both ends included (``curve`` periodic: equal ends).
    curve : ndarray, shape (m,)
    n_bins : int

    Returns
    -------
    ndarray, shape (n_bins,)
        ``mean over phi in [j/n, (j+1)/n) of curve(phi)``, by the trapezoid rule on the grid
        (linear interpolation between grid points), bin j's centre at (j + 0.5)/n.
    """
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    out = np.empty(n_bins)
    for j in range(n_bins):
        inside = (grid > edges[j]) & (grid < edges[j + 1])
        x = np.concatenate([[edges[j]], grid[inside], [edges[j + 1]]])
        y = np.interp(x, grid, curve)
        out[j] = np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)) / (edges[j + 1] - edges[j])
    return out


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value


def write_trial_csv(trial: GeneratedTrial, folder, *, n_bins: int = N_PHASE_BINS) -> Path:
    """Write a trial as limbstiff's standard CSV plus a JSON file of its truth.

    The CSV holds ``# key: value`` metadata lines, then the header
    ``time_s,angle_rad,torque_Nm,stiffness_true_Nm_per_rad`` (``,marker`` for ensembles: read
    it with a protocol whose ``[cycles]`` says ``marker = "marker"``), then one row per sample,
    every number at full precision (``%.17g``: read back bit for bit).
    ``<name>.truth.json`` beside it holds ``params``, and for ensembles the true stiffness by
    phase (``truth_by_phase``: the mean of K over each of ``n_bins`` equal bins, with the bins'
    centres) and the fine curve (``truth_grid``, ``truth_curve``).

    Parameters
    ----------
    trial : GeneratedTrial
    folder : path-like
        Created if missing.
    n_bins : int
        Phase bins of ``truth_by_phase``.

    Returns
    -------
    Path
        The CSV file, ``folder / (trial.name + ".csv")``.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    columns = [trial.time, trial.angle, trial.torque, trial.stiffness_true]
    headers = [HEADERS[k] for k in ("time", "angle", "torque", "stiffness_true")]
    if trial.marker is not None:
        columns.append(trial.marker)
        headers.append(HEADERS["marker"])
    lines = []
    for key, value in trial.metadata.items():
        key, value = str(key).strip(), " ".join(str(value).splitlines())
        if not key or ":" in key:
            raise ValueError(f"metadata key {key!r} cannot be written as '# key: value'")
        lines.append(f"# {key}: {value}")
    path = folder / f"{trial.name}.csv"
    with open(path, "w", encoding="utf-8", newline="\n") as out:
        out.write("".join(line + "\n" for line in lines))
        np.savetxt(out, np.column_stack(columns), fmt="%.17g", delimiter=",", header=",".join(headers),
                   comments="")
    truth = {"name": trial.name, "params": trial.params}
    if trial.truth_curve is not None:
        truth["truth_by_phase"] = {"n_bins": n_bins, "centre": (np.arange(n_bins) + 0.5) / n_bins,
                                   "stiffness_Nm_per_rad": trial.truth_by_phase(n_bins)}
        truth["truth_grid"], truth["truth_curve"] = trial.truth_grid, trial.truth_curve
    (folder / f"{trial.name}.truth.json").write_text(json.dumps(_jsonable(truth), indent=1) + "\n",
                                                     encoding="utf-8")
    return path


def write_all(trials, folder) -> list[Path]:
    """Write every trial (:func:`write_trial_csv`) and return the CSV paths."""
    return [write_trial_csv(t, folder) for t in trials]
