# Track stiffness K = Q/delta against the grain size (size_scale x the EN 13450 grading) for the two DEM drivers, from
# the runs' records: YADE's spheres on the desk (results/*_summary.json of this folder) and the polyhedra library's
# (dem_driver = "standalone") on the desk's CPU and the GPU machine (benchmarks/results/track_stiffness_standalone),
# against the thesis's k_sub and the high-speed-line range (Irazábal 2017 §7.2.1). README, "The thesis's grading".
# Usage: /usr/bin/python3 cases/track_stiffness/grain_size_plot.py  -> cases/track_stiffness/result_grain_size.png
import glob
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RECORDS = os.path.join(ROOT, "benchmarks", "results", "track_stiffness_standalone")
THESIS_K_SUB, RANGE = 102.22, (70.0, 110.0)  # kN/mm (case.py)


def points(paths):
    """[(size_scale, K [kN/mm], sleepers, label)] of the summaries at `paths` that ran the default's load and base."""
    found = []
    for path in sorted(paths):
        with open(path) as f:
            summary = json.load(f)
        p, m = summary["parameters"], summary["metrics"]
        other = p.get("wheel_load_N") != 150000.0 or p.get("base_young") != 0.03e9 or p["smoke"]
        if summary["case"] != "track_stiffness" or other:
            continue  # other cases, loads or bases: the README's other studies
        # a record's folder names the run (h200_...: the GPU machine); this folder's summaries their file
        folder = os.path.basename(os.path.dirname(path))
        found.append((p["size_scale"], m["track_stiffness_kN_per_mm"], p["sleepers"],
                      os.path.basename(path) if folder == "results" else folder))
    return found


yade = points(glob.glob(os.path.join(HERE, "results", "*summary.json")))
standalone = points(glob.glob(os.path.join(RECORDS, "*", "*", "summary.json")))
fig, ax = plt.subplots(figsize=(7.5, 4.6))
ax.axhspan(*RANGE, color="0.9", label="high-speed lines, 70-110 kN/mm (López Pita)")
ax.axhline(THESIS_K_SUB, ls="--", color="k", lw=1, label="thesis k_sub 102.22 kN/mm (grading x 1)")
# YADE's runs, the library's on the desk CPU and on the H200, side by side at each size (the CPU's and the H200's
# runs on one bed coincide: 37.47 against 37.46 kN/mm).
kinds = {"yade": ("s", "none", -0.03, "YADE (desk)"), "cpu": ("o", "none", 0.0, "polyhedra library, desk CPU"),
         "h200": ("o", None, 0.03, "polyhedra library, H200")}
for data, driver in ((yade, "yade"), (standalone, None)):
    for scale, k, sleepers, label in data:
        marker, face, shift, name = kinds[driver or ("h200" if label.startswith("h200") else "cpu")]
        shift += 0.0 if sleepers == 3 else 0.03  # beside the 3-sleeper runs of the same size
        ax.plot(scale + shift, k, marker, ms=8, mfc=face, color="C0" if sleepers == 3 else "C1",
                label=f"{name}, {sleepers} sleepers")
handles, labels = ax.get_legend_handles_labels()
unique = dict(zip(labels, handles))
ax.legend(unique.values(), unique.keys(), fontsize=8, loc="center right")
ax.set_xlabel("grain size: size_scale x EN 13450 (22.4-63 mm)")
ax.set_ylabel("track stiffness K = Q / delta [kN/mm]")
ax.set_xlim(0.8, 2.2)
ax.set_ylim(0, 120)
ax.grid(alpha=0.3)
ax.set_title("quarter track under 150 kN, base 0.03 GPa (scaled by size_scale^1.5)", fontsize=10)
fig.tight_layout()
out = os.path.join(HERE, "result_grain_size.png")
fig.savefig(out, dpi=120)
print(out)
for scale, k, sleepers, label in yade + standalone:
    print(f"  x {scale:g}, {sleepers} sleepers: K {k:.1f} kN/mm  ({label})")
