#!/usr/bin/python3
"""Checks of a structure script that is not the box solver: freefem_scripts/examples/monoblock_sleeper.edp (a gmsh
mesh, coupled through freefem_scripts/lib/coupling_loop.idp).

Subcommands (each one CTest test, label freefem):
  own_structure_coupled  the gmsh sleeper's volume and base against its outline (monoblock_sleeper.geo); coupled runs
                         (just-in-time, predictive, implicit with a repeated pass per window) against a stand-in DEM
                         (uniform pressure over the bridge, which checks the interface's area and orientation)
                         reproduce the script's direct run step by step (just-in-time, implicit) or one step late
                         (predictive) and settle on its static solution

Usage: check_own_structure.py SUBCOMMAND --freefem FreeFem++ --solver monoblock_sleeper.edp --plugin-dir DIR
           --lib-dir DIR --work DIR --dem railcosim_test_pressure_dem
"""

import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_box_elastodynamics as box  # noqa: E402  (its solver runner and checks; this folder is on sys.path)

expect = box.expect  # one list of failures for run_checks

# The outline of monoblock_sleeper.geo: base 0.30 m wide, top 0.17 m, height 0.214 m except 0.175 m over the middle
# 0.40 m with 0.20 m tapers; every section is a trapezoid whose height varies linearly between stations, so the
# volume is the exact integral of the section area 0.235 h(x).
BASE_WIDTH, TOP_WIDTH, LENGTH = 0.30, 0.17, 2.6
HEIGHT_INTEGRAL = 1.8 * 0.214 + 2 * 0.2 * (0.214 + 0.175) / 2 + 0.4 * 0.175  # m^2, integral of h(x) dx
VOLUME = (BASE_WIDTH + TOP_WIDTH) / 2 * HEIGHT_INTEGRAL                     # m^3
DENSITY = 2400.0                                                            # kg/m^3, the script's default
# The sloping sides of the two tapers join sections of different height: twisted (bilinear) faces, which gmsh's flat
# triangles approximate. A bilinear face lies between the two ways of splitting its quadrilateral ABCD into two
# triangles, and the volume between those is the tetrahedron ABCD, |det(B - A, C - A, D - A)| / 6; four such faces.
TWIST_VOLUME = 4 * (0.2 * (BASE_WIDTH - TOP_WIDTH) / 2 * (0.214 - 0.175)) / 6   # m^3


def own_structure_coupled(args):
    if not args.dem:
        sys.exit("own_structure_coupled needs --dem (the railcosim_test_pressure_dem executable)")
    geometry = os.path.join(os.path.dirname(args.solver), "monoblock_sleeper.geo")
    pressure = 1000.0   # Pa on the base
    windows = 80
    dt = 2e-4
    # The coarsest mesh of the convergence study (5,313 dofs) keeps the runs short. Mass-proportional damping
    # a_M = 3000 1/s: damping ratio a_M / 2 omega = 0.65 of the middle span's first bending mode (~2300 rad/s,
    # 360 Hz for a clamped 1.5 m span), 1 at 1500 rad/s; every mode then decays at >= ~1500 1/s, so 80 windows
    # (16 ms) leave < e^-20 of the transient.
    common = ["-geo", geometry, "-meshSize", 0.14, "-dt", dt, "-rayleighMass", 3000.0, "-progressEvery", 0,
              "-averageSteps", 5]
    static, _ = box.run_solver(args, "sleeper_static", common + ["-mode", "static", "-pressure", pressure])
    mesh = ["-mesh", os.path.join(args.work, "sleeper_static", "sleeper.msh")]

    # The gmsh mesh against the outline: within the twisted faces' bound (measured 1.6e-4 at this size, the bound
    # 2.7e-3); a base or top width wrong by 1 cm moves the volume by 2 %.
    volume_error = abs(static["mass"] / DENSITY - VOLUME) / VOLUME
    expect(volume_error <= TWIST_VOLUME / VOLUME, "gmsh sleeper volume %.6f m^3 vs the outline's %.6f m^3 (relative %.1e, "
           "bound %.1e)" % (static["mass"] / DENSITY, VOLUME, volume_error, TWIST_VOLUME / VOLUME))
    # The base is flat: its triangles cover exactly 2.6 x 0.3 m (round-off only).
    base_error = abs(static["baseArea"] - LENGTH * BASE_WIDTH) / (LENGTH * BASE_WIDTH)
    expect(base_error <= 1e-12, "interface (label 1) area %.12f m^2 = 0.78 (relative %.1e)" % (static["baseArea"], base_error))
    force_error = abs(static["finalTotalForce"][2] + pressure * LENGTH * BASE_WIDTH) / (pressure * LENGTH * BASE_WIDTH)
    expect(force_error <= 1e-12, "lumped static load = p x base area (relative %.1e)" % force_error)

    box.run_solver(args, "sleeper_direct", common + mesh + ["-mode", "direct", "-pressure", pressure, "-steps", windows])
    direct = box.read_monitor(args, "sleeper_direct")
    results = {}
    for scheme in ("justInTime", "predictive", "implicit"):
        endpoint = "ipc://" + os.path.join(args.work, "sleeper_%s.sock" % scheme)

        def start_dem():
            # The stand-in checks every triangle faces +z (the base turned up: counter-clockwise from outside) and
            # that the triangles cover 0.78 m^2; started once FreeFEM runs (mesh and assembly outlast its patience).
            return subprocess.Popen([args.dem, "--endpoint", endpoint, "--pressure", repr(pressure), "--windows",
                                     str(windows), "--scheme", scheme, "--area", repr(LENGTH * BASE_WIDTH),
                                     "--normal", "0,0,1", "--trapezoid", "1", "--timeout", "60"],
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

        name = "sleeper_coupled_" + scheme
        summary, output = box.run_solver(args, name, common + mesh + ["-mode", "coupled", "-scheme", scheme,
                                                                      "-endpoint", endpoint, "-timeout", 60],
                                         start_background=start_dem)
        print("  " + "\n  ".join(line for line in output.splitlines() if "railcosim_test_pressure_dem" in line))
        results[scheme] = (summary, box.read_monitor(args, name))

    # Overdamped: 16 ms leave far less of the transient than the settling check allows.
    box.schemes_reproduce_direct(results, direct, static, windows)


def main():
    return box.run_checks(__doc__, ["own_structure_coupled"], globals(), "check_own_structure")


if __name__ == "__main__":
    sys.exit(main())
