#!/usr/bin/python3
"""Figures of one steel-sheet run's histories that its summary does not hold: the back-bending after the peak, the
deflection and the mass flow rate averaged over a chosen span (the steady stream of a run whose hopper empties before
its end), the flow's peak, when the flow falls below a fraction of its steady rate, and the wall time split.

Usage: /usr/bin/python3 cases/steel_sheet/history_figures.py RUN [RUN ...] [--span A,B] [--fraction F] [--json FILE]
RUN: a results folder (summary.json, dem_info.json, dem_timeseries.h5, fem/fem_monitor.csv). --span: the steady span
[s] (default: the run's plateau_from_s to its end); --fraction: the flow's fall (default 0.9 of the steady rate).
"""
import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "..", "python")]
import case as steel  # noqa: E402  (flow_rate: the case's own history of the mass flow rate)
import history_error  # noqa: E402  (history: a run's deflection at the sensor)
from railcosim import results  # noqa: E402


def figures(folder, span=None, fraction=0.9):
    summary = results.read_json(os.path.join(folder, "summary.json"))
    p = summary["parameters"]
    dem, series = results.read_json(os.path.join(folder, "dem_info.json")), results.read_dem_series(folder)
    found = history_error.history(folder)
    if found is None:
        raise SystemExit(f"history_figures.py: {folder} has no finished run (summary.json, fem/fem_monitor.csv)")
    t, w = found
    lo, hi = span if span else (p["plateau_from_s"], float(t[-1]))
    k = int(np.argmax(w))
    after = (t > t[k]) & (t < t[k] + 0.2)
    td, passed = series["time"], series["passed_mass"]
    rate = steel.flow_rate(td, passed, p["flow_smoothing_s"])
    steady = (np.interp(hi, td, passed) - np.interp(lo, td, passed)) / (hi - lo)
    late = np.flatnonzero((td > lo) & (rate < fraction * steady))
    return {"run": folder, "grains": dem["particles"], "backend": dem.get("polyhedra_backend", "yade"),
            "peak_deflection_m": float(w[k]), "peak_time_s": float(t[k]),
            "back_bending_m": float(w[after].min()), "back_bending_time_s": float(t[after][np.argmin(w[after])]),
            "span_s": [lo, hi], "span_mean_deflection_m": float(w[(t >= lo) & (t <= hi)].mean()),
            "span_mass_flow_kg_per_s": float(steady), "flow_peak_kg_per_s": float(np.nanmax(rate)),
            "flow_peak_time_s": float(td[np.nanargmax(rate)]),
            "flow_below_fraction_s": float(td[late[0]]) if late.size else None,
            "peak_per_flow_mm_s_per_kg": float(w[k] / steady * 1e3),
            "span_deflection_per_flow_mm_s_per_kg": float(w[(t >= lo) & (t <= hi)].mean() / steady * 1e3),
            "coupled_wall_s": summary["wall_time_s"], "dem_s": dem.get("polyhedra_time_s"),
            "fem_wait_s": dem.get("wait_time_s"), "restart_checkpoints_s": dem.get("restart_checkpoint_time_s")}


def main(argv):
    parser = argparse.ArgumentParser(prog="history_figures.py")
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--span", help="A,B [s]: the steady span")
    parser.add_argument("--fraction", type=float, default=0.9)
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    span = tuple(float(v) for v in args.span.split(",")) if args.span else None
    if span and not (len(span) == 2 and span[0] < span[1]):
        parser.error("--span needs A,B with A < B")
    try:
        rows = [figures(run, span, args.fraction) for run in args.runs]
    except FileNotFoundError as error:
        parser.error(str(error))
    for row in rows:
        print(json.dumps(row, indent=1))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
