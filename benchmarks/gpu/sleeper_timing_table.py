#!/usr/bin/env python3
"""Timing table of a sleeper_on_ballast run in the form of Ullrich (2022) Table 6.2: total, DEM, FEM, coupling, in
minutes and % of the total. Usage: sleeper_timing_table.py RUN_FOLDER [LABEL] (prints markdown).

From the run's summary.json (total wall time, the preparation's) and dem_info.json (the DEM process's clocks): DEM =
the polyhedra system's stepping (bed preparation: its whole wall time, which is DEM and its Python stage logic);
FEM = the DEM side's wait for the FEM solver; coupling = bridge (encoding, transfer) + force lumping + the implicit
scheme's snapshots; script = the DEM script's own share of each window (sensor readings, time series; runs from
2026-11-29 on); other = the rest of the coupled run (start-up, the post-processing, and the script's share when not
measured)."""
import json
import os
import sys


def table(folder, label):
    with open(os.path.join(folder, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(folder, "dem_info.json")) as f:
        dem = json.load(f)
    total = summary["total_wall_time_s"]
    preparation = sum(run["wall_time_s"] for run in summary.get("preparation", {}).values())
    rows = [("bed preparation (DEM)", preparation), ("load run: DEM", dem["polyhedra_time_s"]),
            ("load run: FEM", dem["wait_time_s"]),
            ("load run: coupling", dem["bridge_time_s"] + dem["mapping_time_s"] + dem["checkpoint_time_s"])]
    if "script_time_s" in dem:
        rows.append(("load run: script (sensors, records)", dem["script_time_s"]))
    rows.append(("other", total - sum(t for _, t in rows)))
    steps = dem["implicit_passes"] * dem["subcycles"] if dem["scheme"] == "implicit" else dem["steps"]
    lines = [f"| {label} | min | % |", "|---|---|---|"]
    lines += [f"| {name} | {t / 60:.2f} | {100 * t / total:.1f} |" for name, t in rows]
    lines.append(f"| **total** | **{total / 60:.2f}** | 100 |")
    lines.append("")
    lines.append(f"{dem['stones']} stones, {dem['polyhedra_backend']} ({dem.get('dem_driver', 'yade')} driver); load run "
                 f"{dem['exchanges']} windows, {steps} DEM steps over all passes at {dem['dt']:.3g} s: "
                 f"{steps * dem['stones'] / dem['polyhedra_time_s']:.3g} particle-steps/s in the coupled run.")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else os.path.basename(os.path.abspath(sys.argv[1]))))
