"""pvrsim from Python in five steps: a render, data from numpy, a simulated
cluster with its timeline, a sweep as a DataFrame, and errors.

    pip install ./python pandas matplotlib
    python python/examples/quickstart.py [OUT_DIR]      # writes OUT_DIR/*.png (default quickstart/)

Runs on the small aorta bundled with the repository (tests/data) in a few
seconds.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; drop this line in a notebook
import matplotlib.pyplot as plt
import numpy as np

import pvrsim

REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "tests" / "data" / "aorta-small-view-b.toml"
out = Path(sys.argv[1] if len(sys.argv) > 1 else "quickstart")
out.mkdir(parents=True, exist_ok=True)

# 1. Render a scene file: every `pvrsim render` option is a keyword.
res = pvrsim.render(SCENE, threads=1, ert=0.9)
print(res.image.shape, res.image.dtype, f"{res.stats['time_total_s']:.3f} s,",
      res.stats["cells_projected"], "cells projected")
plt.imsave(out / "render.png", res.image[..., :3])  # RGB: the PNG `pvrsim render` writes

# 2. Data from numpy: the same mesh, passed as arrays, with a field of our own.
mesh = pvrsim.Mesh.read(REPO / "tests" / "data" / "aorta-small.vtk")
height = mesh.points[:, 2].astype(np.float64)
arrays = pvrsim.Mesh.from_arrays(mesh.points, mesh.tets, point_data={"height": height})
scene = pvrsim.Scene.fit(arrays, field="height", view="-y", size=(300, 200))
plt.imsave(out / "height.png", pvrsim.render(scene).image[..., :3])
scene.save(out / "height.toml")  # writes height.vtk next to it: `pvrsim render` reads both

# 3. A simulated cluster of 4 nodes: report, per-node table, timeline.
cl = pvrsim.cluster(SCENE, nodes=4, ert=0.9, share=True, dlb=True)
print(cl.nodes[["cells_processed", "cells_skipped_ert", "idle_s"]])
colors = {"scan": "tab:blue", "compute": "tab:cyan", "share": "tab:orange", "steal": "tab:red",
          "composite": "tab:green", "send": "tab:purple", "recv": "tab:pink", "idle": "lightgray"}
fig, ax = plt.subplots(figsize=(8, 2.5))
for activity, rows in cl.timeline.groupby("activity"):
    for node, r in rows.groupby("node"):
        ax.broken_barh(list(zip(r["start_s"], r["end_s"] - r["start_s"])), (node - 0.4, 0.8),
                       color=colors.get(activity, "black"), label=activity)
handles = {h.get_label(): h for h in ax.get_legend_handles_labels()[0]}
ax.legend(handles.values(), handles.keys(), ncol=4, fontsize=7, loc="upper right")
# Ranks 0..N-1 are the nodes; the simulated manager has the next rank.
ranks = sorted(cl.timeline["node"].unique())
ax.set(xlabel="seconds (virtual clock)", yticks=ranks,
       yticklabels=[f"node {n}" if n < cl.ranks else "manager" for n in ranks])
fig.tight_layout()
fig.savefig(out / "timeline.png", dpi=120)

# 4. A sweep (the config `pvrsim sweep` runs) as a DataFrame of its runs.
df = pvrsim.sweep(REPO / "configs" / "smoke.toml")
mean = df.groupby(["integrator", "width", "tile"])["time_scan_s"].mean().reset_index()
fig, ax = plt.subplots(figsize=(5, 3.5))
for (integrator, width), g in mean.groupby(["integrator", "width"]):
    ax.plot(g["tile"], g["time_scan_s"] * 1e3, marker="o", label=f"{integrator}, {width} px")
ax.set(xscale="log", xlabel="tile (px)", ylabel="scan time (ms)", title="smoke sweep")
ax.set_xticks(sorted(mean["tile"].unique()), [str(t) for t in sorted(mean["tile"].unique())])
ax.minorticks_off()
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out / "sweep.png", dpi=120)

# 5. Errors carry the command line's messages.
try:
    pvrsim.render(SCENE, ert=1.5)
except pvrsim.OptionError as e:  # also a ValueError
    print("refused:", e)

print("wrote", ", ".join(str(p) for p in sorted(out.glob("*.png"))))
