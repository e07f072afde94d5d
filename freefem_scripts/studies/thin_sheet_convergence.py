#!/usr/bin/python3
"""Thin structures: the steel sheet of the wheat draw-down rig as a solid shell of P2 tetrahedra, against closed forms.

The sheet of Dratt & Katterfeld's (2017) rig as simulated by Ullrich 2022 (ch. 5, Table 5.1): 340 x 100 x 0.75 mm,
clamped over 60 mm at one end, E = 185 GPa, nu = 0.3, rho = 7850 kg/m^3. Only the free span is modelled: the
box x = 60..340 mm (sheet coordinates: x from the clamped end, y across, z up from the bottom face) with its
x = 60 mm face clamped (face 4), the top face coupled (face 6). box_elastodynamics.edp meshes it with cube()
(nx x ny x nz hexahedra, 6 P2 tetrahedra each, nz = 1 or 2 through the thickness) and optionally grades the grid
towards the clamp (-gridLinesX at t, 2t, 4t, ...: the clamp stops the Poisson change of thickness, a boundary
layer about one thickness long that elements of 13 thicknesses smear over their length, stiffening the root).

Two problems, each with a reference that is exact for it:

  strip   the sheet in cylindrical bending: side faces y = 0 and y = b on rollers (-slip 1,3: u_y = 0), i.e. a
          plate strip in plane strain. Tip deflection under a uniform pressure q and the bending frequencies
              w(L) = q L^4 / (8 D),  D = E t^3 / (12 (1 - nu^2)),
              f_n = (beta_n L)^2 / (2 pi L^2) sqrt(D / (rho t)),  beta_1 L = 1.8751, beta_2 L = 4.6941
          (Timoshenko & Woinowsky-Krieger 1959, Theory of Plates and Shells, ch. 1: a beam of stiffness D; the
          cantilever roots of cos(bL) cosh(bL) = -1, Blevins 1979, Formulas for Natural Frequency and Mode Shape).
          Shear deformation and rotary inertia change them by (t/L)^2 terms: 8e-6 for the
          deflection (Timoshenko shear part 2 / (3 kappa (1 - nu)) (t/L)^2), below 1e-4 for f_2.
  plate   the real sheet, free long edges (CFFF in Leissa's notation). Reference: the Kirchhoff plate solved here by
          the Rayleigh-Ritz method with Legendre polynomials (w = xi^2 P_i(2 xi - 1) P_j(2 eta - 1), xi = x/L,
          eta = y/b; exact Gauss quadrature; bending and torsion modes from the symmetric and antisymmetric
          y-families). Every Ritz value is an upper bound of the exact plate frequency. For the square CFFF plate
          (nu = 0.3) Leissa (1969, NASA SP-160; 1973, J. Sound Vib. 31:257) tabulates
          lambda = omega a^2 sqrt(rho t / D) = 3.4917, 8.5246, 21.429, 27.331, 31.111 from a 36-term beam-function
          Ritz series; this series gives 3.4710, 8.5063, 21.284, 27.199, 30.955 (printed by the study), all lower by
          0.2-0.6 %, i.e. closer to the exact values. It is evaluated at the sheet's own aspect ratio L/b = 2.8
          (no interpolation between Leissa's tabulated ratios 1.5 and 2.5). Bracketing it: the beam (anticlastic
          curvature free, stiffness E t^3 / 12 per width) and the strip (anticlastic curvature suppressed, D);
          the clamp suppresses it near the root, so the plate lies between the two.

Per mesh the study runs five solves (strip static and modal, plate static and modal, and a plate direct run at
dt = 1e-4 s with Bossak alpha_B = -0.1 for the factorisation and step times) and prints, and writes with --save,
the convergence table: cells, dofs, errors of the tip deflection and of the frequencies, factorisation [s] of the
Newmark effective matrix and the mean step [ms] (CPU seconds). With --dynamics it also releases the chosen plate
from its static deflection at dt = 1e-4 s and fits the first frequency to the tip motion (with the modal bending
frequencies 2 and 3 it also excites), for alpha_B = 0 and -0.1. The chosen mesh (CHOSEN) is checked by the CTests freefem_thin_sheet_* (tests/freefem/
check_thin_sheet.py), which import this module's closed forms.

Usage:
    /usr/bin/python3 freefem_scripts/studies/thin_sheet_convergence.py --plugin-dir BUILD/freefem_scripts/plugin
        [--quick] [--dynamics] [--save DIR] [--work /tmp/thin_sheet_convergence]
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import scipy.linalg
from numpy.polynomial import legendre

from sleeper_convergence import freefem_environment

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SOLVER = os.path.join(REPO, "freefem_scripts", "solvers", "box_elastodynamics.edp")

# The sheet (Ullrich 2022, Table 5.1), in sheet coordinates.
SHEET_LENGTH, WIDTH, THICKNESS = 0.34, 0.1, 0.75e-3   # m
CLAMP_LENGTH = 0.06                                   # m, clamped over x = 0..60 mm
SPAN = SHEET_LENGTH - CLAMP_LENGTH                    # m, free span (the modelled box)
YOUNGS_MODULUS, POISSON_RATIO, DENSITY = 185e9, 0.3, 7850.0
PRESSURE = 1.0                                        # Pa, static checks (linear: only ratios are reported)
DT = 1e-4                                             # s, the rig's coupling step (Ullrich 2022, sec. 5.4)
ALPHA_BOSSAK = -0.1                                   # Wood, Bossak & Zienkiewicz 1980 (Ullrich's alpha = 0.1)
BETA_L = (1.87510407, 4.69409113)                     # cantilever: roots of cos(x) cosh(x) = -1
# Leissa 1969/1973, CFFF square plate, nu = 0.3 (beam-function Ritz, 36 terms).
LEISSA_SQUARE = (3.4917, 8.5246, 21.429, 27.331, 31.111)

# Meshes of the study: (order, nx, ny, nz, graded). The chosen one is checked by the CTests.
MESHES = [(2, 14, 5, 1, False), (2, 28, 10, 1, False), (2, 56, 20, 1, False), (2, 112, 40, 1, False),
          (2, 14, 5, 1, True), (2, 28, 10, 1, True), (2, 28, 10, 2, True), (2, 42, 14, 1, True),
          (2, 56, 20, 1, True), (2, 56, 20, 2, True), (2, 112, 40, 1, True),
          (1, 112, 40, 2, True)]
QUICK_SKIPS = [(2, 112, 40, 1, False), (2, 112, 40, 1, True), (2, 56, 20, 2, True), (1, 112, 40, 2, True)]
CHOSEN = (2, 28, 10, 1, True)


# ------------------------------------------------------------------------------------------------
# Closed forms
def flexural_rigidity():
    """D = E t^3 / (12 (1 - nu^2)) [N m]."""
    return YOUNGS_MODULUS * THICKNESS ** 3 / (12.0 * (1.0 - POISSON_RATIO ** 2))


def frequency_scale():
    """f = lambda * this [Hz] for lambda = omega L^2 sqrt(rho t / D)."""
    return math.sqrt(flexural_rigidity() / (DENSITY * THICKNESS)) / (2.0 * math.pi * SPAN ** 2)


def strip_closed_form(pressure=PRESSURE):
    """Plate strip in cylindrical bending: (tip deflection [m], [f_1, f_2] [Hz])."""
    return (pressure * SPAN ** 4 / (8.0 * flexural_rigidity()),
            [beta ** 2 * frequency_scale() for beta in BETA_L])


def beam_bounds(pressure=PRESSURE):
    """Euler-Bernoulli beam of stiffness E t^3 b / 12 (anticlastic curvature free): (tip deflection, [f_1, f_2])."""
    deflection, frequencies = strip_closed_form(pressure)
    factor = 1.0 - POISSON_RATIO ** 2
    return deflection / factor, [f * math.sqrt(factor) for f in frequencies]


def _legendre_basis(terms, points, clamped):
    """Values, first and second derivatives on [0, 1] of P_i(2s - 1), times s^2 when `clamped` (w = w' = 0 at 0)."""
    values = np.zeros((3, terms, len(points)))
    for i in range(terms):
        coefficients = np.zeros(i + 1)
        coefficients[-1] = 1.0
        p = legendre.legval(2 * points - 1, coefficients)
        dp = 2 * legendre.legval(2 * points - 1, legendre.legder(coefficients))
        ddp = 4 * legendre.legval(2 * points - 1, legendre.legder(coefficients, 2))
        if clamped:
            values[:, i] = (points ** 2 * p, 2 * points * p + points ** 2 * dp,
                            2 * p + 4 * points * dp + points ** 2 * ddp)
        else:
            values[:, i] = (p, dp, ddp)
    return values


def kirchhoff_cantilever_plate(aspect, poisson_ratio=POISSON_RATIO, terms=20, modes=3):
    """Rayleigh-Ritz solution of the Kirchhoff plate clamped at x = 0, free elsewhere (CFFF), length L along x,
    width b = L / aspect. Energy (nondimensional, xi = x/L, eta = y/b, r = L/b):
        U = int w_xixi^2 + r^4 w_etaeta^2 + 2 nu r^2 w_xixi w_etaeta + 2 (1 - nu) r^2 w_xieta^2,  T = lambda^2 int w^2
    (Leissa 1969, ch. 1). Returns {"bending": [lambda...], "torsion": [lambda...], "tipCentre": w(L, b/2),
    "tipEdge": w(L, 0), "tipMean": mean of w(L, y)} with deflections in units of q L^4 / D."""
    gauss_points, gauss_weights = legendre.leggauss(60)   # exact for the products of degree <= 2 (terms + 1)
    points, weights = (gauss_points + 1) / 2, gauss_weights / 2
    along = _legendre_basis(terms, points, True)
    across = _legendre_basis(terms, points, False)

    def gram(basis, p, q):
        return (basis[p] * weights) @ basis[q].T

    r = aspect
    stiffness = (np.kron(gram(along, 2, 2), gram(across, 0, 0)) + r ** 4 * np.kron(gram(along, 0, 0), gram(across, 2, 2))
                 + poisson_ratio * r ** 2 * (np.kron(gram(along, 2, 0), gram(across, 0, 2))
                                             + np.kron(gram(along, 0, 2), gram(across, 2, 0)))
                 + 2 * (1 - poisson_ratio) * r ** 2 * np.kron(gram(along, 1, 1), gram(across, 1, 1)))
    mass = np.kron(gram(along, 0, 0), gram(across, 0, 0))
    # P_j(2 eta - 1) is even about the centre line for even j: bending, odd j: torsion.
    result = {}
    for name, parity in (("bending", 0), ("torsion", 1)):
        keep = [i * terms + j for i in range(terms) for j in range(terms) if j % 2 == parity]
        eigenvalues = scipy.linalg.eigh(stiffness[np.ix_(keep, keep)], mass[np.ix_(keep, keep)], eigvals_only=True)
        result[name] = [float(math.sqrt(v)) for v in eigenvalues[:modes]]
    load = np.kron(along[0] @ weights, across[0] @ weights)
    coefficients = np.linalg.solve(stiffness, load)
    tip = _legendre_basis(terms, np.array([1.0]), True)[0][:, 0]
    for name, eta in (("tipEdge", 0.0), ("tipCentre", 0.5)):
        result[name] = float(np.kron(tip, _legendre_basis(terms, np.array([eta]), False)[0][:, 0]) @ coefficients)
    result["tipMean"] = float(np.kron(tip, across[0] @ weights) @ coefficients)
    return result


def plate_reference(pressure=PRESSURE):
    """The free-edge sheet as a Kirchhoff plate: (tip deflection at mid-width [m], {bending: [f1, f2], torsion: [f1]})."""
    ritz = kirchhoff_cantilever_plate(SPAN / WIDTH)
    scale = frequency_scale()
    return (ritz["tipCentre"] * pressure * SPAN ** 4 / flexural_rigidity(),
            {"bending": [scale * v for v in ritz["bending"][:2]], "torsion": [scale * ritz["torsion"][0]]})


def bossak_amplification(omega_dt, alpha=ALPHA_BOSSAK):
    """Spectral radius, damping ratio and relative period error of one Bossak-Newmark step (gamma = 1/2 - alpha,
    beta = (1 - alpha)^2 / 4) on u'' + omega^2 u = 0, from the amplification matrix of the recurrence of
    lib/newmark.idp (Wood, Bossak & Zienkiewicz 1980; Hughes 1987, The Finite Element Method, ch. 9)."""
    gamma, beta = 0.5 - alpha, 0.25 * (1 - alpha) ** 2
    columns = []
    for state in np.eye(3):  # (u, v dt, a dt^2) with omega dt = omega_dt, dt = 1
        u0, v0, a0 = state
        predicted_u = u0 + v0 + (0.5 - beta) * a0
        predicted_v = v0 + (1 - gamma) * a0
        # (1 - alpha) a1 + alpha a0 + omega^2 u1 = 0,  u1 = predicted_u + beta a1
        a1 = -(alpha * a0 + omega_dt ** 2 * predicted_u) / ((1 - alpha) + omega_dt ** 2 * beta)
        columns.append([predicted_u + beta * a1, predicted_v + gamma * a1, a1])
    eigenvalues = np.linalg.eigvals(np.array(columns).T)
    radius = float(max(abs(eigenvalues)))
    principal = max(eigenvalues, key=lambda z: abs(z.imag) if abs(z) > 0.5 * radius else -1)
    phase = abs(math.atan2(principal.imag, principal.real))
    damping = -math.log(abs(principal)) / phase if phase > 0 else float("nan")
    return radius, damping, (omega_dt / phase - 1.0) if phase > 0 else float("nan")


# ------------------------------------------------------------------------------------------------
# FreeFEM runs
def root_grid_lines(nx, origin_x=CLAMP_LENGTH):
    """Grid lines at t, 2t, 4t, ... from the clamped end while shorter than 3/4 of the mean cell length."""
    lines, offset = [], THICKNESS
    while offset < 0.75 * SPAN / nx:
        lines.append(origin_x + offset)
        offset *= 2
    return lines


def sheet_arguments(order, cells, graded, strip=False, origin=(CLAMP_LENGTH, 0.0, 0.0)):
    """box_elastodynamics.edp options of the sheet's free span (geometry, material, clamp, coupled top face);
    `strip` puts the side faces on rollers (cylindrical bending)."""
    arguments = ["-order", order, "-origin", "%r,%r,%r" % tuple(origin), "-Lx", SPAN, "-Ly", WIDTH, "-Lz", THICKNESS,
                 "-nx", cells[0], "-ny", cells[1], "-nz", cells[2], "-E", YOUNGS_MODULUS, "-nu", POISSON_RATIO,
                 "-rho", DENSITY, "-clamped", "4", "-coupled", 6]
    if graded:
        arguments += ["-gridLinesX", ",".join(repr(x) for x in root_grid_lines(cells[0], origin[0]))]
    if strip:
        arguments += ["-slip", "1,3"]
    return arguments


def tip_probes(origin=(CLAMP_LENGTH, 0.0, 0.0)):
    """Tip points on the mid-surface: mid-width, and the two corners (bending vs torsion)."""
    x, z = origin[0] + SPAN, origin[2] + THICKNESS / 2
    return [(x, origin[1] + WIDTH / 2, z), (x, origin[1], z), (x, origin[1] + WIDTH, z)]


def run_solver(freefem, plugin_dir, arguments, out, timeout=1200):
    """Runs the solver; returns (fem_summary, fem_modes or None, wall seconds)."""
    probes = tip_probes()
    command = [freefem, "-nw", "-v", "0", SOLVER] + [str(a) for a in arguments] + [
        "-probes", ",".join("%r,%r,%r" % p for p in probes), "-monitor", "%r,%r,%r" % probes[0], "-out", out]
    start = time.time()
    result = subprocess.run(command, env=freefem_environment(plugin_dir), capture_output=True, text=True,
                            timeout=timeout)
    wall = time.time() - start
    if result.returncode != 0:
        sys.exit("thin_sheet_convergence: FreeFem++ failed (exit %d) for %s:\n%s%s"
                 % (result.returncode, out, result.stdout[-2000:], result.stderr[-2000:]))
    with open(os.path.join(out, "fem_summary.json")) as handle:
        summary = json.load(handle)
    modes = None
    if os.path.exists(os.path.join(out, "fem_modes.json")):
        with open(os.path.join(out, "fem_modes.json")) as handle:
            modes = json.load(handle)["modes"]
    return summary, modes, wall


def classify_modes(modes):
    """Splits plate modes into bending (tip corners move together) and torsion (opposite) frequencies [Hz]."""
    bending, torsion = [], []
    for mode in modes:
        _, edge, other_edge = (shape[2] for shape in mode["probeShapes"])
        (bending if edge * other_edge > 0 else torsion).append(mode["frequency"])
    return bending, torsion


def tip_deflection(summary):
    """Downward deflection [m] at the tip's mid-width on the mid-surface (the first probe)."""
    return -summary["probeDisplacements"][0][2]


def run_mesh(freefem, plugin_dir, mesh, work):
    """The five solves of one mesh; returns the row of the table."""
    order, nx, ny, nz, graded = mesh
    name = "P%d_%dx%dx%d%s" % (order, nx, ny, nz, "_graded" if graded else "")
    strip_args = sheet_arguments(order, (nx, ny, nz), graded, strip=True)
    plate_args = sheet_arguments(order, (nx, ny, nz), graded)
    strip_static, _, _ = run_solver(freefem, plugin_dir, ["-mode", "static", "-pressure", PRESSURE] + strip_args,
                                    os.path.join(work, name, "strip_static"))
    _, strip_modes, _ = run_solver(freefem, plugin_dir, ["-mode", "modal", "-modes", 2] + strip_args,
                                   os.path.join(work, name, "strip_modal"))
    plate_static, _, _ = run_solver(freefem, plugin_dir, ["-mode", "static", "-pressure", PRESSURE] + plate_args,
                                    os.path.join(work, name, "plate_static"))
    _, plate_modes, _ = run_solver(freefem, plugin_dir, ["-mode", "modal", "-modes", 4] + plate_args,
                                   os.path.join(work, name, "plate_modal"))
    direct, _, _ = run_solver(freefem, plugin_dir, ["-mode", "direct", "-pressure", PRESSURE, "-steps", 20, "-dt", DT,
                                                    "-alphaB", ALPHA_BOSSAK, "-progressEvery", 0] + plate_args,
                              os.path.join(work, name, "plate_direct"))
    strip_deflection, strip_frequencies = strip_closed_form()
    plate_deflection, plate_frequencies = plate_reference()
    bending, torsion = classify_modes(plate_modes)
    return {
        "order": order, "cells": [nx, ny, nz], "graded": graded, "dofs": strip_static["dofs"],
        "interfaceNodes": strip_static["interfaceNodes"],
        "strip": {"deflection": tip_deflection(strip_static),
                  "deflectionError": tip_deflection(strip_static) / strip_deflection - 1,
                  "frequencies": [m["frequency"] for m in strip_modes],
                  "frequencyErrors": [m["frequency"] / f - 1 for m, f in zip(strip_modes, strip_frequencies)]},
        "plate": {"deflection": tip_deflection(plate_static),
                  "deflectionError": tip_deflection(plate_static) / plate_deflection - 1,
                  "bending": bending[:2], "torsion": torsion[:1],
                  "bendingErrors": [f / r - 1 for f, r in zip(bending, plate_frequencies["bending"])],
                  "torsionErrors": [f / r - 1 for f, r in zip(torsion, plate_frequencies["torsion"])]},
        "factorisationSeconds": direct["factorisationSeconds"], "stepSeconds": direct["meanStepSeconds"],
    }


def fitted_frequency(times, values, guess, other_frequencies):
    """Frequency [Hz] of the dominant mode in a free vibration: least squares of
        u(t) = sum_k a_k cos(omega_k t) + b_k sin(omega_k t)
    with omega_0 free (golden-section search within 1 % of `guess`) and the other omega_k fixed at
    `other_frequencies` (the higher modes the release excites, which shift zero crossings by 0.2 % here).
    Returns (frequency, amplitude of the dominant mode, rms residual / max |u|)."""
    times, values = np.asarray(times), np.asarray(values)

    def fit(omega):
        columns = []
        for w in [omega] + [2 * math.pi * f for f in other_frequencies]:
            columns += [np.cos(w * times), np.sin(w * times)]
        matrix = np.array(columns).T
        coefficients = np.linalg.lstsq(matrix, values, rcond=None)[0]
        return float(np.sum((matrix @ coefficients - values) ** 2)), coefficients

    low, high = 2 * math.pi * guess * 0.99, 2 * math.pi * guess * 1.01
    golden = (math.sqrt(5) - 1) / 2
    for _ in range(80):
        left, right = high - golden * (high - low), low + golden * (high - low)
        if fit(left)[0] < fit(right)[0]:
            high = right
        else:
            low = left
    omega = 0.5 * (low + high)
    residual, coefficients = fit(omega)
    return (omega / (2 * math.pi), math.hypot(coefficients[0], coefficients[1]),
            math.sqrt(residual / len(values)) / float(np.max(np.abs(values))))


def release_run(freefem, plugin_dir, mesh, alpha, steps, bending, work):
    """Free vibration of the plate released from its static deflection under PRESSURE, Bossak alpha_B = alpha at
    dt = DT. `bending`: the mesh's modal bending frequencies [Hz]. Returns (fitted f_1, its amplitude relative to the
    static tip deflection, fit residual, largest rise of the energy above its initial value, summary)."""
    order, nx, ny, nz, graded = mesh
    out = os.path.join(work, "release_alpha%g" % alpha)
    summary, _, _ = run_solver(freefem, plugin_dir, ["-mode", "direct", "-release", 1, "-pressure", PRESSURE,
                                                     "-steps", steps, "-dt", DT, "-alphaB", alpha, "-progressEvery", 0]
                               + sheet_arguments(order, (nx, ny, nz), graded), out)
    with open(os.path.join(out, "fem_monitor.csv")) as handle:
        rows = list(csv.DictReader(handle))
    tip = [float(r["uz"]) for r in rows]
    frequency, amplitude, residual = fitted_frequency([float(r["time"]) for r in rows], tip, bending[0], bending[1:])
    energy = [float(r["kineticEnergy"]) + float(r["strainEnergy"]) for r in rows]
    return frequency, amplitude / abs(tip[0]), residual, max(energy[1:]) / energy[0] - 1, summary


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin-dir", required=True, help="folder holding railcosim_bridge.so")
    parser.add_argument("--freefem", default="FreeFem++")
    parser.add_argument("--work", default="/tmp/thin_sheet_convergence", help="folder for the solver outputs")
    parser.add_argument("--quick", action="store_true", help="skip the finest meshes")
    parser.add_argument("--dynamics", action="store_true",
                        help="also release the chosen plate at dt = 1e-4 s (alpha_B = 0 and -0.1)")
    parser.add_argument("--save", default="", help="folder for thin_sheet_convergence.json, .csv and .md")
    args = parser.parse_args()
    lines = []

    def say(text=""):
        print(text)
        lines.append(text)
        sys.stdout.flush()

    strip_deflection, strip_frequencies = strip_closed_form()
    beam_deflection, beam_frequencies = beam_bounds()
    plate_deflection, plate_frequencies = plate_reference()
    square = kirchhoff_cantilever_plate(1.0, modes=5)
    square_modes = sorted(square["bending"] + square["torsion"])[:5]
    say("Steel sheet %g x %g x %g mm, free span %g mm (clamped over %g mm), E = %g Pa, nu = %g, rho = %g kg/m^3; "
        "D = %.5f N m." % (1e3 * SHEET_LENGTH, 1e3 * WIDTH, 1e3 * THICKNESS, 1e3 * SPAN, 1e3 * CLAMP_LENGTH,
                          YOUNGS_MODULUS, POISSON_RATIO, DENSITY, flexural_rigidity()))
    say("Strip (cylindrical bending): tip deflection q L^4 / (8 D) = %.6e m at q = %g Pa; f_1 = %.4f Hz, "
        "f_2 = %.4f Hz." % (strip_deflection, PRESSURE, strip_frequencies[0], strip_frequencies[1]))
    say("Beam (E t^3 b / 12): tip deflection %.6e m, f_1 = %.4f Hz, f_2 = %.4f Hz." % (
        beam_deflection, beam_frequencies[0], beam_frequencies[1]))
    say("Kirchhoff plate, L/b = %.2f (Ritz, 20 x 20 Legendre terms): tip deflection at mid-width %.6e m; bending "
        "f_1 = %.4f Hz, f_2 = %.4f Hz; torsion f_1 = %.4f Hz (lambda = %.4f, %.4f; %.4f)." % (
            SPAN / WIDTH, plate_deflection, plate_frequencies["bending"][0], plate_frequencies["bending"][1],
            plate_frequencies["torsion"][0], plate_frequencies["bending"][0] / frequency_scale(),
            plate_frequencies["bending"][1] / frequency_scale(), plate_frequencies["torsion"][0] / frequency_scale()))
    say("Ritz check, square CFFF plate: lambda = %s vs Leissa's %s (both upper bounds)." % (
        ", ".join("%.4f" % v for v in square_modes), ", ".join("%g" % v for v in LEISSA_SQUARE)))
    say("Plate between beam and strip: f_1 %.1f %% of the way from beam to strip, tip deflection %.1f %%." % (
        100 * (plate_frequencies["bending"][0] - beam_frequencies[0]) / (strip_frequencies[0] - beam_frequencies[0]),
        100 * (beam_deflection - plate_deflection) / (beam_deflection - strip_deflection)))
    for name, frequency in (("f_1", plate_frequencies["bending"][0]), ("f_2", plate_frequencies["bending"][1])):
        radius, damping, elongation = bossak_amplification(2 * math.pi * frequency * DT)
        say("Bossak alpha_B = %g at dt = %g s, %s: omega dt = %.2e, damping ratio %.1e, period error %+.1e; "
            "spectral radius at omega dt -> infinity %.4f." % (ALPHA_BOSSAK, DT, name, 2 * math.pi * frequency * DT,
                                                            damping, elongation, bossak_amplification(1e6)[0]))
    say()
    say("| elements | cells (along x across x through) | root graded | dofs | interface nodes | strip w error | "
        "strip f1 error | strip f2 error | plate w error | plate f1 error | plate torsion error | plate f2 error | "
        "factorisation [s] | step [ms] |")
    say("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for mesh in MESHES:
        if args.quick and mesh in QUICK_SKIPS:
            continue
        row = run_mesh(args.freefem, args.plugin_dir, mesh, args.work)
        rows.append(row)
        order, nx, ny, nz, graded = mesh
        bold = "**" if mesh == CHOSEN else ""

        def percent(value):
            return "%+.2f %%" % (100 * value)
        say("| %sP%d%s | %s%d x %d x %d%s | %s | %d | %d | %s | %s | %s | %s | %s | %s | %s | %.2f | %.1f |" % (
            bold, order, bold, bold, nx, ny, nz, bold, "yes" if graded else "no", row["dofs"], row["interfaceNodes"],
            percent(row["strip"]["deflectionError"]), percent(row["strip"]["frequencyErrors"][0]),
            percent(row["strip"]["frequencyErrors"][1]), percent(row["plate"]["deflectionError"]),
            percent(row["plate"]["bendingErrors"][0]), percent(row["plate"]["torsionErrors"][0]),
            percent(row["plate"]["bendingErrors"][1]), row["factorisationSeconds"], 1e3 * row["stepSeconds"]))

    dynamics = {}
    if args.dynamics:
        say()
        order, nx, ny, nz, graded = CHOSEN
        _, modes, _ = run_solver(args.freefem, args.plugin_dir, ["-mode", "modal", "-modes", 4]
                                 + sheet_arguments(order, (nx, ny, nz), graded), os.path.join(args.work, "chosen_modal"))
        bending, _ = classify_modes(modes)
        # 3500 steps = 0.35 s, 2.7 periods of f_1.
        for alpha in (0.0, ALPHA_BOSSAK):
            frequency, amplitude, residual, energy_rise, summary = release_run(
                args.freefem, args.plugin_dir, CHOSEN, alpha, 3500, bending, args.work)
            dynamics["alpha%g" % alpha] = {"frequency": frequency, "modalFrequency": bending[0],
                                           "amplitude": amplitude, "fitResidual": residual,
                                           "energyRise": energy_rise, "stepSeconds": summary["meanStepSeconds"]}
            say("Release of the chosen plate, dt = %g s, alpha_B = %g: f_1 fitted to the tip motion %.5f Hz vs modal "
                "%.5f Hz (%+.1e); mode-1 amplitude %.4f of the static deflection (fit residual %.1e); energy rise "
                "above the initial %.1e; mean step %.1f ms." % (
                    DT, alpha, frequency, bending[0], frequency / bending[0] - 1, amplitude, residual, energy_rise,
                    1e3 * summary["meanStepSeconds"]))

    if args.save:
        os.makedirs(args.save, exist_ok=True)
        with open(os.path.join(args.save, "thin_sheet_convergence.json"), "w") as handle:
            json.dump({"closedForms": {"strip": {"deflection": strip_deflection, "frequencies": strip_frequencies},
                                       "beam": {"deflection": beam_deflection, "frequencies": beam_frequencies},
                                       "plate": {"deflection": plate_deflection, "frequencies": plate_frequencies}},
                       "pressure": PRESSURE, "chosen": list(CHOSEN), "rows": rows, "dynamics": dynamics}, handle,
                      indent=2)
        with open(os.path.join(args.save, "thin_sheet_convergence.csv"), "w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["order", "nx", "ny", "nz", "graded", "dofs", "interfaceNodes", "stripDeflectionError",
                             "stripF1Error", "stripF2Error", "plateDeflectionError", "plateF1Error",
                             "plateTorsionError", "plateF2Error", "factorisationSeconds", "stepSeconds"])
            for row in rows:
                writer.writerow([row["order"], *row["cells"], int(row["graded"]), row["dofs"], row["interfaceNodes"],
                                 row["strip"]["deflectionError"], *row["strip"]["frequencyErrors"],
                                 row["plate"]["deflectionError"], row["plate"]["bendingErrors"][0],
                                 row["plate"]["torsionErrors"][0], row["plate"]["bendingErrors"][1],
                                 row["factorisationSeconds"], row["stepSeconds"]])
        with open(os.path.join(args.save, "thin_sheet_convergence.md"), "w") as handle:
            handle.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
