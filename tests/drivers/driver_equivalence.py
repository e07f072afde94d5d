#!/usr/bin/python3
"""The two DEM drivers of a case give the same run: YADE's engines (dem_driver = "yade") and the polyhedra library
without YADE (dem_driver = "standalone", the GPU machine's path), on the CPU reference with one OpenMP thread.

Usage: driver_equivalence.py RAILCOSIM CASE_DIR OUT [--set name=value ...]

Runs the case twice (`railcosim run CASE --smoke --set dem_driver=... --set dem_threads=1 --set
polyhedra_backend=cpu`, each with its own bed cache), then requires, bit for bit:
  - the bed files: every dataset (bodies, plate histories) and the seat height, time step and porosity;
  - the DEM time series (dem_timeseries.h5: interface force, sensor forces and heights, interface work, time);
  - the FEM side's monitor (fem/fem_monitor.csv), which the DEM forces drive.
The oracle is determinism: both drivers build the same polyhedra system from the same bed (BodyFrameStones), step it
in the same batches and couple it through the same window code (PolyhedraWindow, DemCouplingScheme), and the CPU
reference repeats itself exactly on one thread (PolyhedraSystem.hpp). Any difference in what either driver hands the
library, in what order, shows up as a difference in the chaotic granular motion long before the end of the run.
"""
import argparse
import os
import shutil
import subprocess
import sys

import numpy as np


def run(railcosim, case, out, driver, sets):
    folder = os.path.join(out, driver)
    command = [railcosim, "run", case, "--smoke", "--force", "--out", folder, "--set", f"dem_driver={driver}",
               "--set", "dem_threads=1", "--set", "polyhedra_backend=cpu",
               "--set", f"bed_cache_dir={os.path.join(out, 'beds-' + driver)}"]
    for s in sets:
        command += ["--set", s]
    result = subprocess.run(command)
    if result.returncode not in (0, 3):  # 3: a physics check failed, which is the case's business, not this test's
        raise SystemExit(f"{driver} run failed (exit {result.returncode}): {' '.join(command)}")
    return folder


def compare_h5(a, b, what):
    import h5py
    problems = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        names = set()
        fa.visit(lambda n: names.add(n) if isinstance(fa[n], h5py.Dataset) else None)
        other = set()
        fb.visit(lambda n: other.add(n) if isinstance(fb[n], h5py.Dataset) else None)
        if names != other:
            problems.append(f"{what}: datasets differ: {sorted(names ^ other)}")
        for name in sorted(names & other):
            x, y = fa[name][()], fb[name][()]
            if x.shape != y.shape:
                problems.append(f"{what}/{name}: shapes {x.shape} vs {y.shape}")
            elif not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                difference = np.nanmax(np.abs(np.asarray(x, float) - np.asarray(y, float)))
                problems.append(f"{what}/{name}: differs (largest difference {difference:.3e})")
        attrs = {k: (fa.attrs[k], fb.attrs.get(k)) for k in ("seat_height_m", "time_step_s", "porosity", "stones")
                 if k in fa.attrs}
        for k, (x, y) in attrs.items():
            if x != y:
                problems.append(f"{what}: attribute {k} {x!r} vs {y!r}")
        print(f"{what}: {len(names & other)} datasets compared" + (f", {attrs}" if attrs else ""), flush=True)
    return problems


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("railcosim")
    parser.add_argument("case")
    parser.add_argument("out")
    parser.add_argument("--set", action="append", default=[])
    args = parser.parse_args()
    shutil.rmtree(args.out, ignore_errors=True)
    os.makedirs(args.out)
    folders = {d: run(args.railcosim, args.case, args.out, d, args.set) for d in ("yade", "standalone")}
    problems = []
    beds = {d: [os.path.join(args.out, f"beds-{d}", f) for f in os.listdir(os.path.join(args.out, f"beds-{d}"))
                if f.endswith(".h5")] for d in folders}
    if any(len(b) != 1 for b in beds.values()):
        problems.append(f"one bed file per driver expected: {beds}")
    else:
        problems += compare_h5(beds["yade"][0], beds["standalone"][0], "bed")
    problems += compare_h5(*(os.path.join(f, "dem_timeseries.h5") for f in folders.values()), "dem_timeseries")
    monitors = [open(os.path.join(f, "fem", "fem_monitor.csv")).read() for f in folders.values()]
    if monitors[0] != monitors[1]:
        problems.append("fem/fem_monitor.csv differs")
    print(f"fem_monitor.csv: {monitors[0].count(chr(10))} lines compared", flush=True)
    for p in problems:
        print("MISMATCH", p)
    if problems:
        sys.exit(1)
    print("the YADE and the standalone driver gave the same bed and the same coupled run, bit for bit")


if __name__ == "__main__":
    main()
