"""The contract between a case folder and the runner (`railcosim run`): the hooks of a case, and their loading.

A case is a folder cases/NAME with
  case.toml   name, expected_wall_s, restart_test_timeout_s (CTest limit of case_NAME_restart, default 90 s),
              the tables [parameters], [coupling], [fem], [output], [limits], [smoke]
              (railcosim/parameters.py: shared defaults, ranges, --set and --smoke)
  case.py     one subclass of Case below: only what is particular to the case
  dem.py      the YADE participant, a numbered story around railcosim.dem.CoupledDem
  README.md   what is validated, against which reference, how long it takes, the result plot

The runner calls the hooks in this order; p is the resolved parameters ({name: value} over all tables, plus
`smoke` and `case_dir`), out the run's results folder (the solvers run in it), endpoint the run's bridge address:
  check_parameters(p) -> [message]          before anything starts: rules the [limits] table cannot say
  restart_unsupported(p) -> reason | None   before anything starts, with --checkpoint-every or --resume only
  preparation_runs(p, out) -> [(name, argv)] runs the coupled run starts from (e.g. a particle bed), one after the other
  fem_command(p, endpoint, out) -> argv     the FreeFEM participant  } started together,
  dem_command(p, endpoint, out) -> argv     the YADE participant     } watched until both exit
  reference_runs(p, out) -> [(name, argv)]  solver-only runs to compare with, one after the other
  postprocess(p, out) -> dict               summary.json's metrics, reference, relative_error and checks
A check is {name, value, limit} and passes when value <= limit. A case must define postprocess, and
fem_arguments (the structure's FreeFEM options, from which the default fem_command is built) unless it defines
fem_command itself; the other hooks have defaults.

A DEM-only case (a bulk test of the particles alone: no structure, no coupling) says `dem_only = true` at the top
of its case.toml: the runner then starts the YADE participant alone (dem_command; its dem.py uses
railcosim.dem.StandaloneDem), fem_arguments and fem_command are neither required nor called, and what needs the
FEM side (restart checkpoints, --record, --replay-*) is refused. Everything else is the same: parameters with
their [limits], --set and --smoke, reference runs, postprocess and summary.json.
"""
import importlib.util
import inspect
import os
import tomllib

from railcosim import solvers


class CaseError(Exception):
    """A problem with the case definition or the command line, reported without a traceback."""


class Case:
    """Base class of a case's case.py. Override the hooks the case needs; each one's docstring is its contract."""

    # FreeFEM entry script of the coupled and reference runs: a name in freefem_scripts/solvers, or a path relative to
    # freefem_scripts (e.g. "examples/monoblock_sleeper.edp"; solvers.fem_script).
    fem_script = solvers.BOX_SOLVER

    def fem_arguments(self, p):
        """{option: value} of fem_script describing the structure: dimensions, mesh, material, supported and
        coupled faces, monitor point, damping, loads, from the [fem] table (option names as in the script's
        getARGV block). Required unless fem_command is overridden."""
        raise NotImplementedError

    def postprocess(self, p, out):
        """Reads the run's files in out and returns the summary's "metrics", "reference", "relative_error"
        and "checks" (usually with results.participant_summary). Required."""
        raise NotImplementedError

    def check_parameters(self, p):
        """Problems the [limits] rules cannot express (e.g. a DEM step above the critical one), one message each."""
        return []

    def restart_unsupported(self, p):
        """Why a run with these parameters cannot save or resume restart checkpoints (a DEM participant that takes no
        part in them: neither railcosim.dem's nor the standalone polyhedra driver), as one sentence; None when it can.
        The runner refuses --checkpoint-every and --resume with this reason before anything runs."""
        return None

    def duration_s(self, p):
        """Simulated time of the coupled run [s]: the duration_s parameter, unless the case derives it (a load
        pattern's end, say); tools that pace a run by its length (restart checkpoints in tests) ask this."""
        return p["duration_s"]

    def fem_command(self, p, endpoint, out):
        """The FreeFEM participant: fem_script in coupled mode with the [coupling]/[output] options and fem_arguments."""
        return solvers.coupled_fem_command(p, endpoint, out, solvers.fem_script(self.fem_script), self.fem_arguments(p))

    def dem_command(self, p, endpoint, out):
        """The YADE participant: the case folder's dem.py."""
        return solvers.dem_command(p, endpoint, out)

    def preparation_runs(self, p, out):
        """Runs before the coupled one, [(name, argv)], in out, one after the other, their output shown; each must
        succeed before the solvers start (fem_command and dem_command may read what they leave in out)."""
        return []

    def reference_runs(self, p, out):
        """Solver-only runs after the coupled one, [(name, argv)]; each must succeed before postprocess."""
        return []

    def fem_reference(self, p, out, name, mode, **options):
        """(name, argv) of a solver-only run of fem_script on the same structure, in `mode` (static, direct), with
        extra options and the coupled run's linear solver, writing to OUT/name: the usual entry of reference_runs."""
        return name, solvers.freefem_command(solvers.fem_script(self.fem_script), mode, os.path.join(out, name),
                                             {"linearSolver": p["fem_linear_solver"], **options,
                                              **self.fem_arguments(p)})


# Hooks a case must define, and alternatives that stand in for one ({hook: the hook that replaces it}).
REQUIRED_HOOKS = ("postprocess", "fem_arguments")
REPLACED_BY = {"fem_arguments": "fem_command"}


def _overrides(cls, hook):
    return getattr(cls, hook) is not getattr(Case, hook)


def is_dem_only(config):
    """Whether case.toml declares a DEM-only case (`dem_only = true`): the YADE participant runs alone."""
    return config.get("dem_only", False) is True


def check_case_class(cls, where, dem_only=False):
    """Refuses a Case subclass that lacks a required hook or defines a hook with other parameters than Case's.
    A DEM-only case needs no FEM hook."""
    for hook in REQUIRED_HOOKS:
        if dem_only and hook in REPLACED_BY:
            continue
        if not _overrides(cls, hook) and not (hook in REPLACED_BY and _overrides(cls, REPLACED_BY[hook])):
            alternative = f" (or {REPLACED_BY[hook]})" if hook in REPLACED_BY else ""
            raise CaseError(f"{where}: class {cls.__name__} does not define {hook}{inspect.signature(getattr(Case, hook))}"
                            f"{alternative}, a required hook; the hooks are described in python/railcosim/case.py")
    for name, hook in vars(Case).items():
        if name.startswith("_") or not callable(hook) or not _overrides(cls, name):
            continue
        expected, got = inspect.signature(hook), inspect.signature(getattr(cls, name))
        variadic = any(q.kind in (q.VAR_POSITIONAL, q.VAR_KEYWORD) for q in got.parameters.values())
        if len(got.parameters) != len(expected.parameters) and not variadic:
            raise CaseError(f"{where}: {cls.__name__}.{name}{got} should take {expected}")


def load_case(case_dir):
    """(config, case): case.toml as a dict and an instance of the one Case subclass that case.py defines."""
    toml_path = os.path.join(case_dir, "case.toml")
    py_path = os.path.join(case_dir, "case.py")
    for path in (toml_path, py_path):
        if not os.path.isfile(path):
            raise CaseError(f"{case_dir} is not a case folder: {os.path.basename(path)} is missing")
    with open(toml_path, "rb") as f:
        try:
            config = tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise CaseError(f"{toml_path}: {e}") from e
    spec = importlib.util.spec_from_file_location("railcosim_case", py_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    classes = [c for c in vars(module).values()
               if isinstance(c, type) and issubclass(c, Case) and c.__module__ == module.__name__]
    if len(classes) != 1:
        found = f"{len(classes)} ({', '.join(c.__name__ for c in classes)})" if classes else "none"
        raise CaseError(f"{py_path}: expected one subclass of railcosim.case.Case, found {found}")
    if "dem_only" in config and not isinstance(config["dem_only"], bool):
        raise CaseError(f"{toml_path}: dem_only must be true or false, got {config['dem_only']!r}")
    check_case_class(classes[0], py_path, is_dem_only(config))
    case = classes[0]()
    if not _overrides(classes[0], "dem_command") and not os.path.isfile(os.path.join(case_dir, "dem.py")):
        raise CaseError(f"{case_dir}: dem.py is missing (the YADE participant of the default dem_command)")
    return config, case
