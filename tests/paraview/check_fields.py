"""Opens a run's fields.xdmf in ParaView (pvpython), checks it against the run's own records, renders a PNG
(tools/render_fields.py).

usage: tools/virtual_display.sh pvpython check_fields.py RUN_DIR PNG

Oracles, each from a file the snapshots do not come from:
  time steps  = the snapshot count implied by parameters.json (duration_s, fem_dt, snapshot_every_s)
  particles   = dem_info.json "particles" (the DEM side's own count)
  tetrahedra  = fem/fem_summary.json "elements"
  u_z at the monitor point, last snapshot = the fem_monitor.csv row of that time (written by the FEM solver
              at its monitor point, a mesh vertex): the data went through FreeFEM's text, HDF5, XDMF and
              ParaView's reader unchanged to the 10 digits of the snapshot text.
Prints one line per check; exits 1 on a failed one.
"""
import csv
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
from render_fields import blocks_at, render  # noqa: E402  (tools/ is not a package)

run, png = sys.argv[1], sys.argv[2]
failures = []


def check(name, value, expected, tolerance=0.0):
    ok = abs(value - expected) <= tolerance * max(abs(expected), 1e-300) if tolerance else value == expected
    print(f"{'PASS' if ok else 'FAIL'} {name}: {value} (expected {expected}{f', rel. tol. {tolerance}' if tolerance else ''})")
    if not ok:
        failures.append(name)


p = json.load(open(os.path.join(run, "parameters.json")))
windows = round(p["duration_s"] / p["fem_dt"])
every = max(1, round(p["snapshot_every_s"] / p["fem_dt"]))
last, times, blocks = blocks_at(os.path.join(run, "fields.xdmf"))
check("time steps", len(times), windows // every)
print("blocks:", ", ".join(f"{k} ({v.GetNumberOfPoints()} points, {v.GetNumberOfCells()} cells)" for k, v in blocks.items()))

check("particles", blocks["particles"].GetNumberOfPoints(), json.load(open(os.path.join(run, "dem_info.json")))["particles"])
fem = json.load(open(os.path.join(run, "fem", "fem_summary.json")))
structure = blocks["structure"]
check("tetrahedra", structure.GetNumberOfCells(), fem["elements"])

# The vertex at the monitor point: its reference position is the deformed one minus the displacement.
displacement = structure.GetPointData().GetArray("displacement")
monitor = fem["monitorPoint"]
nearest, distance = None, math.inf
for i in range(structure.GetNumberOfPoints()):
    x, u = structure.GetPoint(i), displacement.GetTuple3(i)
    d = math.dist([x[k] - u[k] for k in range(3)], monitor)
    if d < distance:
        nearest, distance = i, d
check("monitor point is a vertex (distance, m)", distance < 1e-9, True)
with open(os.path.join(run, "fem", "fem_monitor.csv")) as f:
    rows = list(csv.DictReader(f))
row = min(rows, key=lambda r: abs(float(r["time"]) - last))
# 1e-8: the snapshot text holds 10 significant digits; the monitor row 12.
check("u_z at the monitor point, last snapshot (m)", displacement.GetTuple3(nearest)[2], float(row["uz"]), 1e-8)
von_mises = structure.GetPointData().GetArray("von_mises")
print(f"von Mises range at t = {last:g} s: {von_mises.GetRange()[0]:.4g} .. {von_mises.GetRange()[1]:.4g} Pa")
if "beam_length" in p:
    # Clamped-clamped beam under its particles' weight W spread along it: mid-span moment W L / 24, fibre stress
    # M (h/2) / (b h^3/12) = W L / (4 b h^2) (Euler-Bernoulli; L/h = 10). 10 %: the particles' pressure on the
    # top face adds sigma_zz ~ W/(L b) (4 % here), the load fluctuates by a few % (force_fluctuation), and the
    # stress, linear over the section, is exact at P2 vertices.
    weight = json.load(open(os.path.join(run, "summary.json")))["metrics"]["particle_weight_n"]
    length, width, height = p["beam_length"], p["beam_width"], p["beam_height"]
    middle = [i for i in range(structure.GetNumberOfPoints())
              if abs(structure.GetPoint(i)[0] - displacement.GetTuple3(i)[0] - length / 2) < 1e-9]
    check("max von Mises stress at mid-span (Pa)", max(von_mises.GetValue(i) for i in middle),
          weight * length / (4 * width * height ** 2), 0.10)

render(os.path.join(run, "fields.xdmf"), png, last)
check("PNG written", os.path.getsize(png) > 1000, True)
sys.stdout.flush()
# Debian's VTK may fail to release the GLX context at interpreter exit under Xvfb (an X error, exit 1) after the
# PNG is written: leave without that teardown.
os._exit(1 if failures else 0)
