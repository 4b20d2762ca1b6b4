"""A picture of an impact frame: the beads of a slice through the axis, drawn to scale and
coloured by speed, from an animation frame (output.animation_interval_s) of a run's folder.

    python3 docs/examples/impact_frame.py RUN_DIR TIME_AFTER_CONTACT_S OUT.png
"""

import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import PatchCollection
from matplotlib.patches import Circle

import dembuf

run, after, out = pathlib.Path(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
summary = json.loads((run / "summary.json").read_text())
frames = dembuf.read_pvd(run / "frames.pvd")
# The frame nearest to the time asked for, counted from the first contact.
wanted = summary["first_contact_time_s"] + after
frame = frames.iloc[(frames["t_s"] - wanted).abs().argmin()]
bodies = dembuf.read_vtp(frame["file"])

slab = 0.0045  # half the width of the slice, about one bead
beads = bodies[(bodies["id"] >= 0) & (bodies["y_m"].abs() < slab)]
speed = (beads[["vx_m_s", "vy_m_s", "vz_m_s"]] ** 2).sum(axis=1) ** 0.5
circles = PatchCollection([Circle((x * 100, z * 100), r * 100) for x, z, r in
                           zip(beads["x_m"], beads["z_m"], beads["radius_m"])], cmap="viridis")
circles.set_array(speed.to_numpy())
circles.set_clim(0, max(speed.max(), 1e-3))

fig, ax = plt.subplots(figsize=(7, 4))
ax.add_collection(circles)
projectile = bodies[bodies["id"] == -1]
for _, p in projectile.iterrows():
    ax.add_patch(Circle((p["x_m"] * 100, p["z_m"] * 100), p["radius_m"] * 100, fill=False,
                        lw=1.5, color="black"))
radius = summary["scene"]["cylinder"]["radius_m"] * 100
ax.set_xlim(-radius, radius)
ax.set_ylim(0, max(beads["z_m"].max() * 100 + 1, projectile["z_m"].max() * 100 + 3))
ax.set_aspect("equal")
ax.set_xlabel("x (cm)")
ax.set_ylabel("z (cm)")
ax.set_title(f"t = {1e3 * (frame['t_s'] - summary['first_contact_time_s']):.1f} ms after "
             f"contact, slice |y| < {slab * 1000:.1f} mm")
fig.colorbar(circles, ax=ax, label="bead speed (m/s)", shrink=0.8)
fig.tight_layout()
fig.savefig(out, dpi=120)
print(f"wrote {out}")
