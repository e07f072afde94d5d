"""Solver commands of a case: FreeFEM runs (coupled participant, solver-only references) and the YADE participant."""
import os
import sys

from railcosim import snapshots

FREEFEM = ["FreeFem++", "-nw", "-v", "0"]
BOX_SOLVER = "box_elastodynamics.edp"


def root():
    """The repository the run uses (set by the `railcosim` launcher)."""
    return os.environ["RAILCOSIM_ROOT"]


def fem_script(name):
    """Path of a FreeFEM entry script: a name alone is one of freefem_scripts/solvers, e.g.
    fem_script("box_elastodynamics.edp"); a relative path is taken from freefem_scripts, e.g.
    fem_script("examples/monoblock_sleeper.edp") (a user's own structure through lib/coupling_loop.idp)."""
    if os.path.dirname(name):
        return os.path.join(root(), "freefem_scripts", name)
    return os.path.join(root(), "freefem_scripts", "solvers", name)


def box_solver():
    """Path of the FreeFEM box elastodynamics solver used by the cases."""
    return fem_script(BOX_SOLVER)


def option_text(value):
    """A FreeFEM command-line value: numbers as Python prints them (str of a float round-trips), booleans 1/0."""
    if isinstance(value, bool):
        return "1" if value else "0"
    return str(value)


def freefem_command(script, mode, out, options):
    """FreeFEM headless on `script` (a path) in `mode`, writing to `out`; options {name: value} become
    -name value, in the getARGV grammar of the entry scripts (freefem_scripts/solvers/*.edp)."""
    argv = FREEFEM + [script, "-mode", mode]
    for name, value in options.items():
        argv += [f"-{name}", option_text(value)]
    return argv + ["-out", out]


def coupling_windows(p):
    """Coupling windows of a run: duration_s in steps of fem_dt (the DEM side counts them the same way)."""
    return int(round(p["duration_s"] / p["fem_dt"]))


def average_steps(p):
    """FEM steps over which the structure's reported figures are averaged: the [output] average_s span, else
    the last step alone."""
    return max(1, int(round(p["average_s"] / p["fem_dt"]))) if "average_s" in p else 1


def progress_period(p):
    """Windows between two progress lines of a solver: progress_lines lines over the run."""
    return max(1, coupling_windows(p) // p["progress_lines"])


def coupled_fem_command(p, endpoint, out, script, structure):
    """The FEM participant of a coupled run: `script` in coupled mode on the run's endpoint, with the [coupling]
    scheme and window (fem_dt), the [output] averaging span and progress period, and the structure's options
    (Case.fem_arguments), the linear solver (fem_linear_solver), snapshots when the run takes them
    (railcosim/snapshots.py); it writes to OUT/fem."""
    options = {"endpoint": endpoint, "scheme": p["scheme"], "dt": p["fem_dt"], "averageSteps": average_steps(p),
               "progressEvery": progress_period(p), "linearSolver": p["fem_linear_solver"], **structure}
    if snapshots.snapshot_windows(p):
        options["snapshotSteps"] = snapshots.snapshot_windows(p)  # one FEM step per window: the DEM's numbering
    return freefem_command(script, "coupled", os.path.join(out, "fem"), options)


def dem_command(p, endpoint, out):
    """The case's dem.py run by YADE with the railcosim engines: dem.py PARAMETERS.json ENDPOINT OUTDIR."""
    return [os.path.join(root(), "railcosim"), "yade", os.path.join(p["case_dir"], "dem.py"),
            os.path.join(out, "parameters.json"), endpoint, out]


def library_dem_command(p, path, *arguments):
    """A DEM script on the polyhedra library without YADE (a standalone driver, the GPU machine's path): this Python
    with dem_threads OpenMP threads (the CPU backend's)."""
    return ["env", f"OMP_NUM_THREADS={p['dem_threads']}", sys.executable, path, *arguments]
