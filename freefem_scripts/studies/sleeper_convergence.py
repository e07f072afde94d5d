#!/usr/bin/python3
"""Element and mesh choice for the sleeper of the sleeper-on-ballast case: a static solve on a Winkler foundation.

The timber sleeper of the box test (Song et al. 2019, as simulated by Ullrich 2022 ch. 6) rests with its bottom face
on vertical springs of modulus k [N/m^3] (a Winkler bed standing in for the ballast) and carries the total load P
as two uniform pressures on 0.15 x 0.2 m rail-seat patches of its top face. box_elastodynamics.edp solves it in
3-D (static mode, P1 or P2 tetrahedra, several meshes); the deflections of the bottom face's centre line under a
rail seat and at mid-length are compared with a finite free-free beam on an elastic foundation loaded by the same
two patch line loads q = P / (2 c) over c = 0.15 m:

  Euler-Bernoulli   EI w'''' + k B w = q(x)             (Hetenyi 1946, Beams on Elastic Foundation: general solution
                                                          w = e^(lx)(C1 cos lx + C2 sin lx) + e^(-lx)(C3 cos lx + C4 sin lx)
                                                          + q / (k B) per load segment, l = (k B / (4 EI))^(1/4);
                                                          free ends M = V = 0, continuity at the patch edges)
  Timoshenko        the same with shear deformation w' = theta + V / (kappa G A), kappa = 10 (1 + nu) / (12 + 11 nu)
                    (Cowper 1966, rectangle)

Both are solved exactly as the first-order system y' = A y + b for y = (w, theta, M, V) on each segment between
patch edges: y(x + h) = y_p + exp(A h) (y(x) - y_p) with the constant particular solution y_p = (q / (k B), 0, 0, 0);
the two unknowns at x = 0 (w, theta; M = V = 0 there) follow from M = V = 0 at x = L. The Euler-Bernoulli solver is
checked here against Hetenyi's explicit formulas for a centre point load on a free beam,
  w(L/2) = P l / (2 k B) (cosh lL + cos lL + 2) / (sinh lL + sin lL),
  w(0)   = 2 P l / (k B) cosh(lL/2) cos(lL/2) / (sinh lL + sin lL).
The area mean of the settlement is exact on any mesh (vertical equilibrium: P = k B L mean(w)) and is reported as a
check of the load and foundation assembly. A patch load on the top face reaches the bed spread through the depth,
which a line load at the beam axis is not: the beam values with the patch widened by H/2 and by H are printed as the
bracket of that model difference. The chosen mesh (CHOSEN) is checked by the CTest freefem_sleeper_winkler
(tests/freefem/check_box_elastodynamics.py), which imports this module's closed form.

Usage:
    /usr/bin/python3 freefem_scripts/studies/sleeper_convergence.py --plugin-dir BUILD/freefem_scripts/plugin
        [--modulus 2e8] [--quick] [--save DIR] [--work /tmp/sleeper_convergence]
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import scipy.linalg

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SOLVER = os.path.join(REPO, "freefem_scripts", "solvers", "box_elastodynamics.edp")

# The sleeper of the box test, in bed coordinates (the 3.2 m bed; sleeper centre at x = 1.6 m).
SLEEPER_START = 0.35                           # m, x of the sleeper's end
LENGTH, WIDTH, HEIGHT = 2.5, 0.2, 0.18          # m
YOUNGS_MODULUS = 9e9                            # Pa, timber along the grain
POISSON_RATIO = 0.3                             # isotropic stand-in for timber (see freefem_scripts/README.md)
DENSITY = 800.0                                 # kg/m^3
RAIL_SEATS = (0.8825, 2.3175)                   # m, patch centres (bed coordinates)
PATCH_LENGTH, PATCH_WIDTH = 0.15, 0.2           # m
PEAK_LOAD = 132e3                               # N, total on the sleeper (half per rail seat)
FOUNDATION_MODULUS = 2e8                        # N/m^3 = 0.2 N/mm^3, the stiff end of ballast bed moduli

# Meshes of the study: (order, nx, ny, nz). The chosen one (README "Sleeper") is checked by the CTest.
MESHES = [(1, 20, 2, 2), (1, 40, 4, 4), (1, 80, 8, 8),
          (2, 10, 1, 1), (2, 20, 2, 2), (2, 20, 2, 4), (2, 40, 2, 2), (2, 40, 4, 4), (2, 80, 4, 4), (2, 80, 8, 8)]
QUICK_SKIPS = [(1, 80, 8, 8), (2, 80, 8, 8)]
CHOSEN = (2, 20, 2, 2)


def beam_properties(poisson_ratio=POISSON_RATIO):
    """Bending stiffness EI [N m^2] and Cowper's shear stiffness kappa G A [N] of the rectangular section."""
    second_moment = WIDTH * HEIGHT ** 3 / 12.0
    shear_modulus = YOUNGS_MODULUS / (2.0 * (1.0 + poisson_ratio))
    kappa = 10.0 * (1.0 + poisson_ratio) / (12.0 + 11.0 * poisson_ratio)
    return YOUNGS_MODULUS * second_moment, kappa * shear_modulus * WIDTH * HEIGHT


def beam_on_foundation(points, modulus, loads, shear_stiffness=math.inf, bending_stiffness=None, state=False):
    """Deflection [m, downward positive] of the free-free beam (x from 0 to LENGTH, sleeper coordinates) on a
    Winkler bed of modulus `modulus` [N/m^3] (times the width: k B [N/m^2]) at the sleeper coordinates `points`,
    under uniform line loads `loads` = [(start, end, q [N/m]), ...]; Timoshenko with `shear_stiffness`
    (kappa G A [N]), Euler-Bernoulli when it is infinite. With `state`, the whole state (w, theta, M [N m], V [N])
    at each point instead (M > 0 compresses the top fibre: M = -EI theta')."""
    if bending_stiffness is None:
        bending_stiffness, _ = beam_properties()
    bed = modulus * WIDTH
    compliance = 0.0 if math.isinf(shear_stiffness) else 1.0 / shear_stiffness
    system = np.array([[0.0, 1.0, 0.0, compliance],
                       [0.0, 0.0, -1.0 / bending_stiffness, 0.0],
                       [0.0, 0.0, 0.0, 1.0],
                       [bed, 0.0, 0.0, 0.0]])

    def line_load(x0, x1):
        middle = 0.5 * (x0 + x1)
        return sum(q for start, end, q in loads if start <= middle <= end)

    cuts = sorted(set([0.0, LENGTH] + [p for p in points] + [e for start, end, _ in loads for e in (start, end)]))
    # Propagate the affine map y(x) = T y(0) + c over the segments (q constant on each).
    transfer, offset = np.eye(4), np.zeros(4)
    states = {0.0: (transfer.copy(), offset.copy())}
    for x0, x1 in zip(cuts[:-1], cuts[1:]):
        step = scipy.linalg.expm(system * (x1 - x0))
        particular = np.array([line_load(x0, x1) / bed, 0.0, 0.0, 0.0])
        transfer = step @ transfer
        offset = particular + step @ (offset - particular)
        states[x1] = (transfer.copy(), offset.copy())
    # Unknowns w(0), theta(0); M(0) = V(0) = 0; free end: M(L) = V(L) = 0.
    transfer, offset = states[cuts[-1]]
    start = np.zeros(4)
    start[:2] = np.linalg.solve(transfer[2:, :2], -offset[2:])
    values = [states[p][0] @ start + states[p][1] for p in points]
    return [tuple(float(v) for v in value) if state else float(value[0]) for value in values]


def patch_line_loads(total_load):
    """The two rail-seat patches as line loads [(start, end, q)] in sleeper coordinates."""
    q = total_load / len(RAIL_SEATS) / PATCH_LENGTH
    return [(c - SLEEPER_START - PATCH_LENGTH / 2, c - SLEEPER_START + PATCH_LENGTH / 2, q) for c in RAIL_SEATS]


def closed_form(modulus, total_load=PEAK_LOAD, patch_length=PATCH_LENGTH):
    """Deflections [m, downward] under the first rail seat and at mid-length: (Euler-Bernoulli, Timoshenko).
    `patch_length` other than the rail seat's spreads the same load over a longer stretch (load spread through
    the depth)."""
    bending, shear = beam_properties()
    points = [RAIL_SEATS[0] - SLEEPER_START, LENGTH / 2]
    loads = [(0.5 * (start + end) - patch_length / 2, 0.5 * (start + end) + patch_length / 2,
              q * PATCH_LENGTH / patch_length) for start, end, q in patch_line_loads(total_load)]
    return (beam_on_foundation(points, modulus, loads, bending_stiffness=bending),
            beam_on_foundation(points, modulus, loads, shear_stiffness=shear, bending_stiffness=bending))


def max_bending_strain(modulus, total_load=PEAK_LOAD):
    """Largest fibre strain |M| (H / 2) / EI of the Timoshenko beam under the rail-seat loads (on a 1 mm grid
    plus the patch edges and centres, where the moment peaks)."""
    bending, shear = beam_properties()
    loads = patch_line_loads(total_load)
    points = sorted(set([i * 1e-3 for i in range(int(round(LENGTH / 1e-3)) + 1)]
                        + [x for start, end, _ in loads for x in (start, end, 0.5 * (start + end))]))
    states = beam_on_foundation(points, modulus, loads, shear_stiffness=shear, bending_stiffness=bending, state=True)
    return max(abs(moment) for _, _, moment, _ in states) * HEIGHT / (2.0 * bending)


def hetenyi_check(modulus):
    """Largest relative difference between the transfer-matrix solver and Hetenyi's explicit centre-load formulas."""
    bending, _ = beam_properties()
    bed = modulus * WIDTH
    lam = (bed / (4.0 * bending)) ** 0.25
    lL = lam * LENGTH
    load = 1.0
    centre = load * lam / (2 * bed) * (math.cosh(lL) + math.cos(lL) + 2) / (math.sinh(lL) + math.sin(lL))
    end = 2 * load * lam / bed * math.cosh(lL / 2) * math.cos(lL / 2) / (math.sinh(lL) + math.sin(lL))
    half = 1e-7  # a point load as a very short patch
    w_end, w_centre = beam_on_foundation([0.0, LENGTH / 2], modulus,
                                         [(LENGTH / 2 - half, LENGTH / 2 + half, load / (2 * half))])
    return max(abs(w_centre - centre) / centre, abs(w_end - end) / abs(end))


def freefem_environment(plugin_dir):
    env = dict(os.environ)
    env["FF_LOADPATH"] = "/usr/lib/freefem++;" + plugin_dir
    env["FF_INCLUDEPATH"] = "/usr/include/freefem++/idp;" + os.path.join(REPO, "freefem_scripts", "lib")
    return env


def sleeper_arguments(order, cells, rail_seats=True):
    """box_elastodynamics.edp options of the sleeper (geometry, material, rail seats; free, coupled bottom face)."""
    arguments = ["-order", order, "-origin", "%r,0,0" % SLEEPER_START, "-Lx", LENGTH, "-Ly", WIDTH, "-Lz", HEIGHT,
                 "-nx", cells[0], "-ny", cells[1], "-nz", cells[2], "-E", YOUNGS_MODULUS, "-nu", POISSON_RATIO,
                 "-rho", DENSITY, "-clamped", "", "-coupled", 5]
    if rail_seats:
        arguments += ["-patchX", ",".join(repr(c) for c in RAIL_SEATS), "-patchLength", PATCH_LENGTH,
                      "-patchWidth", PATCH_WIDTH]
    return arguments


def run_static(freefem, plugin_dir, order, cells, modulus, out):
    """Static Winkler solve; returns (summary, wall seconds). Probes: bottom centre line under the first rail seat
    and at mid-length."""
    probes = [RAIL_SEATS[0], WIDTH / 2, 0.0, SLEEPER_START + LENGTH / 2, WIDTH / 2, 0.0]
    command = [freefem, "-nw", "-v", "0", SOLVER, "-mode", "static"] + sleeper_arguments(order, cells) + [
        "-foundationModulus", modulus, "-peakLoad", PEAK_LOAD, "-probes", ",".join(repr(p) for p in probes),
        "-out", out]
    start = time.time()
    result = subprocess.run([str(c) for c in command], env=freefem_environment(plugin_dir), capture_output=True,
                            text=True, timeout=1200)
    wall = time.time() - start
    if result.returncode != 0:
        sys.exit("sleeper_convergence: FreeFem++ failed (exit %d) for %s:\n%s%s"
                 % (result.returncode, out, result.stdout[-2000:], result.stderr[-2000:]))
    with open(os.path.join(out, "fem_summary.json")) as handle:
        return json.load(handle), wall


def measure(summary):
    """(rail-seat deflection, centre deflection, mean settlement) [m, downward] of a static summary."""
    probes = summary["probeDisplacements"]
    return -probes[0][2], -probes[1][2], -summary["finalFaceMeanUz"]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin-dir", required=True, help="folder holding railcosim_bridge.so")
    parser.add_argument("--freefem", default="FreeFem++")
    parser.add_argument("--modulus", type=float, default=FOUNDATION_MODULUS, help="Winkler modulus k [N/m^3]")
    parser.add_argument("--work", default="/tmp/sleeper_convergence", help="folder for the solver outputs")
    parser.add_argument("--quick", action="store_true", help="skip the finest P1 and P2 meshes")
    parser.add_argument("--save", default="", help="folder for sleeper_convergence.json and .md")
    args = parser.parse_args()

    bending, shear = beam_properties()
    lam = (args.modulus * WIDTH / (4 * bending)) ** 0.25
    (eb_seat, eb_centre), (ti_seat, ti_centre) = closed_form(args.modulus)
    mean_settlement = PEAK_LOAD / (args.modulus * WIDTH * LENGTH)
    beam_strain = max_bending_strain(args.modulus)
    lines = []

    def say(text=""):
        print(text)
        lines.append(text)
        sys.stdout.flush()

    say("Timber sleeper %g x %g x %g m, E = %g Pa, nu = %g, on a Winkler bed k = %.3g N/m^3 (k B = %.3g N/m^2, "
        "lambda = %.4f 1/m, lambda L = %.3f), P = %g N on two %g x %g m rail seats."
        % (LENGTH, WIDTH, HEIGHT, YOUNGS_MODULUS, POISSON_RATIO, args.modulus, args.modulus * WIDTH, lam,
           lam * LENGTH, PEAK_LOAD, PATCH_LENGTH, PATCH_WIDTH))
    say("Closed forms (bottom = beam deflection): rail seat Timoshenko %.5e m (Euler-Bernoulli %.5e m, shear part "
        "%+.2f %%), centre Timoshenko %.5e m (Euler-Bernoulli %.5e m), mean settlement P / (k B L) = %.5e m."
        % (ti_seat, eb_seat, 100 * (ti_seat / eb_seat - 1), ti_centre, eb_centre, mean_settlement))
    # A patch load on the top face reaches the bottom spread over a longer stretch, which a line load at the axis
    # does not have: the beam with the patch widened by H/2 (45 deg to the axis) and by H brackets that effect.
    spread = [closed_form(args.modulus, patch_length=PATCH_LENGTH + extra)[1] for extra in (HEIGHT / 2, HEIGHT)]
    say("Load spread through the depth (Timoshenko, patch %g m widened to %g / %g m): rail seat %.5e / %.5e m "
        "(%+.2f / %+.2f %%), centre %.5e / %.5e m (%+.2f / %+.2f %%)."
        % (PATCH_LENGTH, PATCH_LENGTH + HEIGHT / 2, PATCH_LENGTH + HEIGHT, spread[0][0], spread[1][0],
           100 * (spread[0][0] / ti_seat - 1), 100 * (spread[1][0] / ti_seat - 1), spread[0][1], spread[1][1],
           100 * (spread[0][1] / ti_centre - 1), 100 * (spread[1][1] / ti_centre - 1)))
    say("Largest bending strain of the Timoshenko beam |M| H / (2 EI) = %.4e." % beam_strain)
    say("Transfer-matrix solver vs Hetenyi's centre-load formulas: largest relative difference %.1e."
        % hetenyi_check(args.modulus))
    say()
    say("| elements | cells | dofs | rail seat [m] | error | centre [m] | error | mean settlement error | "
        "max abs(eps_xx) | vs beam | solve [s] | run [s] |")
    say("|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for order, nx, ny, nz in MESHES:
        if args.quick and (order, nx, ny, nz) in QUICK_SKIPS:
            continue
        out = os.path.join(args.work, "k%.3g_P%d_%dx%dx%d" % (args.modulus, order, nx, ny, nz))
        summary, wall = run_static(args.freefem, args.plugin_dir, order, (nx, ny, nz), args.modulus, out)
        seat, centre, mean = measure(summary)
        row = {"order": order, "cells": [nx, ny, nz], "dofs": summary["dofs"], "railSeat": seat, "centre": centre,
               "railSeatError": seat / ti_seat - 1, "centreError": centre / ti_centre - 1,
               "meanSettlementError": mean / mean_settlement - 1, "maxStrainXX": summary["finalMaxStrainXX"],
               "maxStrainXXError": summary["finalMaxStrainXX"] / beam_strain - 1,
               "solveSeconds": summary["factorisationSeconds"], "runSeconds": wall}
        rows.append(row)
        bold = "**" if (order, nx, ny, nz) == CHOSEN else ""
        say("| %sP%d%s | %s%dx%dx%d%s | %d | %.5e | %+.2f %% | %.5e | %+.2f %% | %+.1e | %.4e | %+.1f %% | %.2f | %.1f |"
            % (bold, order, bold, bold, nx, ny, nz, bold, summary["dofs"], seat, 100 * row["railSeatError"], centre,
               100 * row["centreError"], row["meanSettlementError"], row["maxStrainXX"],
               100 * row["maxStrainXXError"], row["solveSeconds"], wall))
    if args.save:
        os.makedirs(args.save, exist_ok=True)
        with open(os.path.join(args.save, "sleeper_convergence.json"), "w") as handle:
            json.dump({"modulus": args.modulus, "peakLoad": PEAK_LOAD, "lambda": lam,
                       "closedForm": {"eulerBernoulli": {"railSeat": eb_seat, "centre": eb_centre},
                                      "timoshenko": {"railSeat": ti_seat, "centre": ti_centre},
                                      "meanSettlement": mean_settlement, "maxBendingStrain": beam_strain},
                       "rows": rows}, handle, indent=2)
        with open(os.path.join(args.save, "sleeper_convergence.md"), "w") as handle:
            handle.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
