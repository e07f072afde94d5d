#!/usr/bin/python3
"""Mesh-convergence study of the clamped-clamped beam (case beam_uniform_load) with box_elastodynamics.edp.

Runs the static solver for P1 and P2 tetrahedra on several meshes, reads the mid-span deflection on
the beam axis from fem_summary.json and prints a Markdown table against the Timoshenko closed form
    delta = w L^4 / (384 E I) + w L^2 / (8 kappa G A),   kappa = 10 (1 + nu) / (12 + 11 nu)
(Cowper 1966, rectangular section; Euler-Bernoulli part from Budynas & Nisbett, Shigley's Table A-9).

Usage:
    /usr/bin/python3 freefem_scripts/studies/beam_convergence.py --plugin-dir BUILD/freefem_scripts/plugin
        [--mass 51] [--quick] [--work /tmp/beam_convergence]
"""

import argparse
import json
import os
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SOLVER = os.path.join(REPO, "freefem_scripts", "solvers", "box_elastodynamics.edp")

# Table 4.1 of Ullrich 2022: steel beam 1000 x 100 x 100 mm, both ends clamped.
LENGTH, WIDTH, HEIGHT = 1.0, 0.1, 0.1      # m
YOUNGS_MODULUS, POISSON_RATIO = 210e9, 0.3  # Pa, -
GRAVITY = 9.81                              # m/s^2, as in Ullrich 2022's load derivation


def closed_form_deflection(line_load):
    """Mid-span deflection [m] of a clamped-clamped Timoshenko beam under a uniform line load [N/m]."""
    second_moment = WIDTH * HEIGHT ** 3 / 12.0
    area = WIDTH * HEIGHT
    shear_modulus = YOUNGS_MODULUS / (2.0 * (1.0 + POISSON_RATIO))
    kappa = 10.0 * (1.0 + POISSON_RATIO) / (12.0 + 11.0 * POISSON_RATIO)
    bending = line_load * LENGTH ** 4 / (384.0 * YOUNGS_MODULUS * second_moment)
    shear = line_load * LENGTH ** 2 / (8.0 * kappa * shear_modulus * area)
    return bending, shear, kappa


def run_case(args, order, cells, load_kind, pressure, work):
    out = os.path.join(work, "P%d_%dx%dx%d_%s" % (order, cells[0], cells[1], cells[2], load_kind))
    env = dict(os.environ)
    env["FF_LOADPATH"] = "/usr/lib/freefem++;" + args.plugin_dir
    env["FF_INCLUDEPATH"] = "/usr/include/freefem++/idp;" + os.path.join(REPO, "freefem_scripts", "lib")
    command = [args.freefem, "-nw", "-v", "0", SOLVER, "-mode", "static", "-order", str(order),
               "-Lx", str(LENGTH), "-Ly", str(WIDTH), "-Lz", str(HEIGHT),
               "-nx", str(cells[0]), "-ny", str(cells[1]), "-nz", str(cells[2]),
               "-E", str(YOUNGS_MODULUS), "-nu", str(POISSON_RATIO), "-clamped", "2,4", "-coupled", "6",
               "-pressure", repr(pressure), "-load", load_kind,
               "-monitor", "%r,%r,%r" % (LENGTH / 2, WIDTH / 2, HEIGHT / 2), "-out", out]
    start = time.time()
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    wall = time.time() - start
    if result.returncode != 0:
        sys.exit("beam_convergence: FreeFem++ failed (exit %d) for %s:\n%s%s"
                 % (result.returncode, out, result.stdout[-2000:], result.stderr[-2000:]))
    with open(os.path.join(out, "fem_summary.json")) as handle:
        summary = json.load(handle)
    return summary, wall


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin-dir", required=True, help="folder holding railcosim_bridge.so")
    parser.add_argument("--freefem", default="FreeFem++")
    parser.add_argument("--mass", type=float, default=51.0, help="particle mass on the beam [kg] (51 or 72)")
    parser.add_argument("--work", default="/tmp/beam_convergence", help="folder for the solver outputs")
    parser.add_argument("--quick", action="store_true", help="skip the two finest meshes")
    args = parser.parse_args()

    line_load = args.mass * GRAVITY / LENGTH         # N/m
    pressure = line_load / WIDTH                      # Pa on the top face
    bending, shear, kappa = closed_form_deflection(line_load)
    reference = bending + shear

    cases = [(1, (20, 2, 2), "lumped"), (1, (40, 4, 4), "lumped"), (1, (80, 8, 8), "lumped"),
             (2, (10, 1, 1), "lumped"), (2, (10, 2, 2), "lumped"), (2, (20, 2, 2), "lumped"),
             (2, (20, 2, 2), "consistent"), (2, (40, 4, 4), "lumped"), (2, (40, 4, 4), "consistent"),
             (2, (80, 8, 8), "lumped")]
    if args.quick:
        cases = [case for case in cases if max(case[1]) < 80]

    print("Clamped-clamped steel beam %g x %g x %g m, E = %g Pa, nu = %g, %g kg of particles: w = %.4g N/m "
          "(p = %.5g Pa on the top face)." % (LENGTH, WIDTH, HEIGHT, YOUNGS_MODULUS, POISSON_RATIO, args.mass,
                                             line_load, pressure))
    print("Closed form: bending %.4e m + shear %.4e m (kappa = %.4f) = %.4e m (Euler-Bernoulli alone %.4e m)."
          % (bending, shear, kappa, reference, bending))
    print()
    print("| elements | cells | load | dofs | deflection [m] | error vs closed form | solve [s] | run [s] |")
    print("|---|---|---|---|---|---|---|---|")
    for order, cells, load_kind in cases:
        summary, wall = run_case(args, order, cells, load_kind, pressure, args.work)
        deflection = -summary["finalMonitorDisplacement"][2]
        error = (deflection - reference) / reference
        print("| P%d | %dx%dx%d | %s | %d | %.4e | %+.2f %% | %.2f | %.1f |"
              % (order, cells[0], cells[1], cells[2], load_kind, summary["dofs"], deflection, 100 * error,
                 summary["factorisationSeconds"], wall))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
