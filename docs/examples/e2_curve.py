"""The E2 curve, the peak plate force P against the bed's thickness, with the spread of the
bed seeds as error bars: from a sweep on the daemon (its id) or a sweep's folder.

    dembuf sweep --preset e2 --vary bed.thickness_m=0:0.08:0.005 --seeds 3   # prints its id
    python3 docs/examples/e2_curve.py SWEEP_ID_OR_FOLDER e2_curve.png
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # files, no window
import matplotlib.pyplot as plt

import dembuf

source, out = sys.argv[1], sys.argv[2]
# One point per thickness, as dembuf computed it: P's mean, sample standard deviation and
# number of seeds (P_N, P_N_sd, P_N_n).
if pathlib.Path(source).is_dir():
    points = dembuf.read_points(source)
else:
    with dembuf.connect() as daemon:
        points = daemon.sweep_points(int(source))
print(points[["bed.thickness_m", "P_N", "P_N_sd", "P_N_n"]].to_string(index=False))

fig, ax = plt.subplots(figsize=(6, 4))
ax.errorbar(points["bed.thickness_m"] * 100, points["P_N"] / 1e3, yerr=points["P_N_sd"] / 1e3,
            fmt="o-", capsize=3, label=f"dembuf, mean and sd of {points['P_N_n'].max()} bed seeds")
ax.set_xlabel("bed thickness H (cm)")
ax.set_ylabel("peak plate force P (kN)")
ax.set_ylim(bottom=0)
ax.grid(alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(out, dpi=120)
print(f"wrote {out}")
