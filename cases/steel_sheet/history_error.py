#!/usr/bin/python3
"""Deflection histories of a stability map (tools/stability_map.py) of the steel-sheet case against its converged run.

Usage: /usr/bin/python3 cases/steel_sheet/history_error.py MAPDIR (--reference KEY=V,KEY=V | --reference-run FOLDER)
For every run of MAPDIR/plan.json (a stability map's or a campaign's): the deflection at the measurement position
(fem/fem_monitor.csv) against the reference run's (the run of MAPDIR with those settings, or a run folder), over
the shorter of the two time lines, interpolated on the run's FEM steps: rms and largest difference over the run, relative to the reference's
peak deflection, the peak's and the final span's deflection errors, and the run's wall time. Writes
MAPDIR/history_error.{md,json,png}.
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python"))
from railcosim import results  # noqa: E402


def history(folder):
    """(time, deflection downward) of a finished run, or None."""
    path = os.path.join(folder, "fem", "fem_monitor.csv")
    if not os.path.isfile(os.path.join(folder, "summary.json")) or not os.path.isfile(path):
        return None
    monitor = results.read_csv_columns(path)
    return monitor["time"], -monitor["uz"]


def timing(folder, summary):
    """Wall seconds of the coupled run split as the seed's Table 5.3: FEM (factorisation + solves x mean solve),
    coupling (both sides' bridge time + the DEM side's force mapping), DEM (the rest: the solvers run in turn)."""
    dem = results.read_json(os.path.join(folder, "dem_info.json"))
    path = os.path.join(folder, "fem", "fem_summary.json")
    if os.path.isfile(path):
        fem = results.read_json(path)
        fem_s = fem.get("factorisationSeconds", 0.0) + fem.get("solves", fem["steps"]) * fem["meanStepSeconds"]
    else:  # a run brought back without it (a GPU machine's): the DEM side's wait for the FEM
        fem_s = dem["wait_time_s"]
    coupling_s = summary["coupling"]["bridge_time_s"] + dem.get("mapping_time_s", 0.0)
    return {"fem_s": fem_s, "coupling_s": coupling_s, "dem_s": summary["wall_time_s"] - fem_s - coupling_s}


def main(argv):
    parser = argparse.ArgumentParser(prog="history_error.py")
    parser.add_argument("mapdir")
    chosen = parser.add_mutually_exclusive_group(required=True)
    chosen.add_argument("--reference", metavar="KEY=V,KEY=V")
    chosen.add_argument("--reference-run", metavar="FOLDER")
    args = parser.parse_args(argv)
    with open(os.path.join(args.mapdir, "plan.json")) as f:
        plan = json.load(f)
    runs = plan["runs"]
    if args.reference:
        wanted = dict(item.split("=", 1) for item in args.reference.split(","))
        matches = [r for r in runs if all(str(r["values"].get(k)) == v for k, v in wanted.items())]
        if not matches:
            sys.exit(f"history_error.py: no run of {args.mapdir} has {args.reference}")
        reference = history(os.path.join(args.mapdir, matches[0]["folder"]))
    else:
        matches = [None]
        reference = history(args.reference_run)
    if reference is None:
        sys.exit("history_error.py: the reference run did not finish")
    t_ref, w_ref = reference
    peak = float(np.max(w_ref))
    rows = []
    for run in runs:
        folder = os.path.join(args.mapdir, run["folder"])
        summary = results.read_json(os.path.join(folder, "summary.json")) if os.path.isfile(
            os.path.join(folder, "summary.json")) else {}
        row = {**run["values"], "status": summary.get("status", "failed"), "wall_time_s": summary.get("wall_time_s"),
               "reference": run is matches[0]}
        found = history(folder)
        if found is not None and summary.get("status") == "ok":
            t, w = found
            # the run's steps only, within the reference's time line
            inside = (t <= t_ref[-1]) & (t >= t_ref[0])
            difference = w[inside] - np.interp(t[inside], t_ref, w_ref)
            end = min(t[-1], t_ref[-1])
            final = (t_ref >= end - 0.1) & (t_ref <= end)
            row.update(**timing(folder, summary))
            row.update(rms_error=float(np.sqrt(np.mean(difference ** 2))) / peak,
                       max_error=float(np.max(np.abs(difference))) / peak,
                       peak_error=abs(float(np.max(w)) - peak) / peak,
                       final_error=abs(float(np.mean(w[(t >= end - 0.1) & (t <= end)])) - float(np.mean(w_ref[final])))
                       / float(np.mean(w_ref[final])),
                       peak_deflection_m=float(np.max(w)))
        rows.append(row)
    keys = sorted({k for r in runs for k in r["values"]})
    pct = lambda v: "–" if v is None else f"{v:.2%}"
    lines = ["| " + " | ".join(keys + ["rms error / peak", "max error / peak", "peak error", "final error", "wall [s]",
                                   "DEM [s]", "FEM [s]", "coupling [s]"]) + " |", "|" + "---|" * (len(keys) + 8)]
    for r in rows:
        cells = [str(r.get(k, "")) for k in keys]
        if r["reference"] and "rms_error" in r:
            cells += ["reference"] * 4
        elif "rms_error" in r:
            cells += [pct(r["rms_error"]), pct(r["max_error"]), pct(r["peak_error"]), pct(r["final_error"])]
        else:
            cells += [f"**{r['status']}**"] * 4
        cells.append("–" if r["wall_time_s"] is None else f"{r['wall_time_s']:.1f}")
        cells += [f"{r[k]:.1f} ({r[k] / r['wall_time_s']:.0%})" if k in r else "–" for k in ("dem_s", "fem_s", "coupling_s")]
        lines.append("| " + " | ".join(cells) + " |")
    with open(os.path.join(args.mapdir, "history_error.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.mapdir, "history_error.json"), "w") as f:
        json.dump({"reference": args.reference or args.reference_run, "reference_peak_m": peak, "runs": rows}, f, indent=2)
    print("\n".join(lines))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 4.5))
    if matches[0] is None:
        ax.plot(t_ref, w_ref * 1e3, lw=2.5, color="k", label=f"{args.reference_run} (reference)")
    for run, r in zip(runs, rows):
        found = history(os.path.join(args.mapdir, run["folder"]))
        if found is not None:
            label = ", ".join(f"{k}={v}" for k, v in run["values"].items())
            ax.plot(found[0], found[1] * 1e3, lw=2.5 if r["reference"] else 1.0, color="k" if r["reference"] else None,
                    label=label + (" (reference)" if r["reference"] else ""))
    ax.set_xlabel("time [s]")
    ax.set_ylabel("deflection [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(args.mapdir, "history_error.png"), dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
