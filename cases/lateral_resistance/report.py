#!/usr/bin/python3
"""Peak lateral force against vertical load from finished runs of the case: a Markdown table and a plot beside the
laboratory line and the thesis's DEM line (Irazábal 2017 eqs. 6.10, 6.11), with the least-squares line of the runs.

Usage: report.py OUT.png RUN_FOLDER... (each a results folder of ./railcosim run cases/lateral_resistance, or a
campaign folder, whose runs/*/rep*/ are read)
"""
import glob
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(os.path.dirname(HERE)), "python")]
from case import LAB_LINE, THESIS_DEM_LINE  # noqa: E402


def summaries(folders):
    for folder in folders:
        paths = [os.path.join(folder, "summary.json")]
        paths += sorted(glob.glob(os.path.join(folder, "runs", "*", "rep*", "summary.json")))
        for path in paths:
            if os.path.isfile(path):
                with open(path) as f:
                    summary = json.load(f)
                if summary.get("status") == "ok" and summary["parameters"]["crest_drop_m"] == 0:
                    yield summary


def main(png, folders):
    rows = sorted(((s["metrics"]["vertical_load_N"], s["metrics"]["peak_lateral_force_N"], s["wall_time_s"],
                    s["metrics"]["base_share_at_peak"]) for s in summaries(folders)))
    if not rows:
        raise SystemExit("no finished run with the crest at its height in " + ", ".join(folders))
    fv, fp = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
    print("| F_v [kN] | F_p here [kN] | lab [kN] | thesis DEM [kN] | here vs lab | base share at peak | wall time [s] |")
    print("|---|---|---|---|---|---|---|")
    for load, peak, wall, base in rows:
        lab = LAB_LINE[0] * load + LAB_LINE[1]
        dem = THESIS_DEM_LINE[0] * load + THESIS_DEM_LINE[1]
        print(f"| {load / 1e3:g} | {peak / 1e3:.2f} | {lab / 1e3:.2f} | {dem / 1e3:.2f} | {(peak - lab) / lab:+.1%} | "
              f"{base:.2f} | {wall:.0f} |")
    fit = np.polyfit(fv, fp, 1) if len(set(fv)) > 1 else None
    if fit is not None:
        print(f"\nleast squares: F_p = {fit[0]:.4f} F_v + {fit[1]:.1f} N (lab 0.7247 F_v + 9011.9 N, "
              f"thesis DEM 0.7442 F_v + 9213.39 N)")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    line = np.linspace(0, max(35e3, fv.max()), 50)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.plot(line / 1e3, (LAB_LINE[0] * line + LAB_LINE[1]) / 1e3, color="C3", label="laboratory (eq. 6.10)")
    ax.plot(line / 1e3, (THESIS_DEM_LINE[0] * line + THESIS_DEM_LINE[1]) / 1e3, color="C2", ls="--",
            label="thesis DEM (eq. 6.11)")
    ax.plot(fv / 1e3, fp / 1e3, "ko", label="this case")
    if fit is not None:
        ax.plot(line / 1e3, np.polyval(fit, line) / 1e3, "k:", label=f"fit: {fit[0]:.3f} F_v + {fit[1] / 1e3:.2f} kN")
    ax.set_xlabel("vertical load F_v [kN]")
    ax.set_ylabel("peak lateral force F_p [kN]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], sys.argv[2:])
