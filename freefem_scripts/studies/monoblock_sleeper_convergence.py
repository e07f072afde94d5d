#!/usr/bin/python3
"""Mesh-convergence study of the gmsh-meshed monoblock sleeper (freefem_scripts/examples/monoblock_sleeper.edp).

Meshes freefem_scripts/examples/monoblock_sleeper.geo with gmsh at several target element sizes, solves the
turned-over sleeper held at its rail seats under a uniform pressure on its base (static mode, P2 tetrahedra)
and prints a Markdown table of the deflection in its middle, on its axis (the example's monitor point), against
the finest mesh. There is no closed form for the tapered 3-D body: the study also prints the Richardson
extrapolation of the three finest meshes, with the order of convergence they show (Roache 1998, Verification and
Validation in Computational Science, ch. 5),
    p = ln((d3 - d2) / (d2 - d1)) / ln(r),   d_inf = d1 + (d1 - d2) / (r^p - 1)
for sizes h1 < h2 < h3 of constant ratio r. It also checks that gmsh makes the same mesh twice (the case meshes
the .geo at run time instead of keeping a .msh).

Usage:
    /usr/bin/python3 freefem_scripts/studies/monoblock_sleeper_convergence.py --plugin-dir BUILD/freefem_scripts/plugin
        [--pressure 3000] [--quick] [--work /tmp/monoblock_sleeper_convergence]
"""

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO, "freefem_scripts", "examples", "monoblock_sleeper.edp")
GEOMETRY = os.path.join(REPO, "freefem_scripts", "examples", "monoblock_sleeper.geo")
SIZES = (0.14, 0.1, 0.07, 0.05, 0.035)  # m, ratio ~1.4 between neighbours


def run_size(args, size):
    out = os.path.join(args.work, "size_%g" % size)
    env = dict(os.environ)
    env["FF_LOADPATH"] = "/usr/lib/freefem++;" + args.plugin_dir
    env["FF_INCLUDEPATH"] = "/usr/include/freefem++/idp;" + os.path.join(REPO, "freefem_scripts", "lib")
    command = [args.freefem, "-nw", "-v", "0", SCRIPT, "-mode", "static", "-geo", GEOMETRY, "-meshSize", repr(size),
               "-pressure", repr(args.pressure), "-out", out]
    start = time.time()
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    wall = time.time() - start
    if result.returncode != 0:
        sys.exit("monoblock_sleeper_convergence: FreeFem++ failed (exit %d) for size %g:\n%s%s"
                 % (result.returncode, size, result.stdout[-2000:], result.stderr[-2000:]))
    with open(os.path.join(out, "fem_summary.json")) as handle:
        return json.load(handle), wall, out


def mesh_digest(size, path):
    subprocess.run(["gmsh", "-3", "-format", "msh22", "-v", "0", "-setnumber", "size", repr(size), GEOMETRY,
                    "-o", path], check=True)
    with open(path, "rb") as handle:
        return hashlib.sha256(handle.read()).hexdigest()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin-dir", required=True, help="folder holding railcosim_bridge.so")
    parser.add_argument("--freefem", default="FreeFem++")
    parser.add_argument("--pressure", type=float, default=3000.0, help="uniform pressure on the base [Pa]")
    parser.add_argument("--work", default="/tmp/monoblock_sleeper_convergence", help="folder for the solver outputs")
    parser.add_argument("--quick", action="store_true", help="skip the finest mesh")
    args = parser.parse_args()
    sizes = SIZES[:-1] if args.quick else SIZES
    os.makedirs(args.work, exist_ok=True)

    same = mesh_digest(0.07, os.path.join(args.work, "a.msh")) == mesh_digest(0.07, os.path.join(args.work, "b.msh"))
    print("gmsh %s: the same .geo meshed twice gives %s files." % (
        subprocess.run(["gmsh", "--version"], capture_output=True, text=True).stderr.strip()
        or subprocess.run(["gmsh", "--version"], capture_output=True, text=True).stdout.strip(),
        "identical" if same else "DIFFERENT"))
    print("Turned-over B70-type sleeper held at its rail seats, %g Pa on its base, P2 tetrahedra." % args.pressure)
    print()
    rows = []
    print("| size [m] | elements | dofs | interface nodes | deflection [m] | vs finest | vs extrapolated | solve [s] | run [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for size in sizes:
        summary, wall, _ = run_size(args, size)
        rows.append((size, summary, wall))
    deflections = [-summary["finalMonitorDisplacement"][2] for _, summary, _ in rows]
    d1, d2, d3 = deflections[-1], deflections[-2], deflections[-3]
    ratio = sizes[-2] / sizes[-1]
    order = math.log(abs((d3 - d2) / (d2 - d1))) / math.log(ratio)
    extrapolated = d1 + (d1 - d2) / (ratio ** order - 1.0)
    for (size, summary, wall), deflection in zip(rows, deflections):
        print("| %g | %d | %d | %d | %.5e | %+.2f %% | %+.2f %% | %.2f | %.1f |"
              % (size, summary["elements"], summary["dofs"], summary["interfaceNodes"], deflection,
                 100 * (deflection - d1) / d1, 100 * (deflection - extrapolated) / extrapolated,
                 summary["factorisationSeconds"], wall))
    print()
    print("Observed order %.2f; extrapolated deflection %.5e m%s; sleeper mass %.1f kg, base %.3f m^2."
          % (order, extrapolated, " (uncertain: an order below 1 means the meshes are not yet in the asymptotic range,"
             " e.g. of the stress singularities at the edges of the held rail seats)" if order < 1 else "",
             rows[-1][1]["mass"], rows[-1][1]["baseArea"]))


if __name__ == "__main__":
    main()
