"""Windowed least squares: the script a lab would write instead of limbstiff (issue 37's peer baseline).

    python benchmarks/ls_baseline.py TRIAL.csv OUT

Reads a trial CSV (``#`` comment lines, then a header with ``time_s``, ``angle_rad`` and
``torque_Nm``) with ``numpy.loadtxt``: NumPy's C reader since 1.23, the plain choice for a
numeric file in a NumPy/SciPy script (pandas.read_csv would parse about as fast but costs its own
import). The angle's derivatives are Savitzky–Golay (51 samples, cubic; the torque smoothed by the
same filter), and in 1 s windows, every 0.5 s, τ = k·θ + b·θ̇ + m·θ̈ + c is fitted by
``numpy.linalg.lstsq``. Writes OUT/stiffness.csv (window centre, k, b, m, c, R²) and
OUT/summary.txt, and prints the summary. Does not use limbstiff.
"""

import sys
from pathlib import Path

import numpy as np
from scipy.signal import savgol_filter

path, out = Path(sys.argv[1]), Path(sys.argv[2])
with open(path) as f:                       # the comment lines, then the header, then the numbers
    header = next(line for line in f if not line.startswith("#")).strip().split(",")
    data = np.loadtxt(f, delimiter=",", usecols=[header.index(c) for c in ("time_s", "angle_rad", "torque_Nm")])
t, angle, torque = data.T
dt = float(np.median(np.diff(t)))
sg = dict(window_length=51, polyorder=3, delta=dt)
theta, dtheta, ddtheta = (savgol_filter(angle, deriv=d, **sg) for d in (0, 1, 2))
tau = savgol_filter(torque, **sg)

width, hop = round(1.0 / dt), round(0.5 / dt)
rows = []
for start in range(0, len(t) - width + 1, hop):
    w = slice(start, start + width)
    X = np.column_stack([theta[w], dtheta[w], ddtheta[w], np.ones(width)])
    coef, *_ = np.linalg.lstsq(X, tau[w], rcond=None)
    r2 = 1 - np.sum((tau[w] - X @ coef) ** 2) / np.sum((tau[w] - tau[w].mean()) ** 2)
    rows.append([t[start + width // 2], *coef, r2])
rows = np.array(rows)

out.mkdir(parents=True, exist_ok=True)
np.savetxt(out / "stiffness.csv", rows, delimiter=",", fmt="%.6g",
           header="time_s,stiffness_Nm_per_rad,damping_Nms_per_rad,inertia_kgm2,offset_Nm,r2", comments="")
k, b, m, r2 = rows[:, 1], rows[:, 2], rows[:, 3], rows[:, 5]
summary = (f"{path.name}: {len(rows)} windows of 1 s; stiffness {k.min():.3g}-{k.max():.3g} N·m/rad "
           f"(median {np.median(k):.3g}); damping {np.median(b):.3g} N·m·s/rad, inertia {np.median(m):.3g} kg·m² "
           f"(medians); R² median {np.median(r2):.3f}")
(out / "summary.txt").write_text(summary + "\n")
print(summary)
