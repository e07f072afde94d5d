"""A case's parameters: case.toml tables with the shared defaults, --smoke and --set overrides, types and ranges."""
import difflib
import math

# The case.toml tables that hold parameters. Their names form one flat namespace (the parameters.json the
# solvers read is flat): a name is unique across the tables, and `--set NAME=VALUE` or `--set TABLE.NAME=VALUE`
# both reach it; [smoke] and [limits] name parameters the same two ways.
#   parameters   the case's own physics: particles, loads, durations, the limits of its checks
#   coupling     the coupling engine and the time steps: scheme, fem_dt, dem_dt or dem_dt_safety, ...
#   fem          the FreeFEM structure: dimensions, mesh, material, damping, loads (case.py turns them into options)
#   output       what is reported: average_s (the final span of the averaged figures), progress_lines
PARAMETER_TABLES = ("parameters", "coupling", "fem", "output")
OTHER_KEYS = ("name", "expected_wall_s", "dem_only", "restart_test_timeout_s", "restart_test_skip", "limits", "smoke")

# Defaults shared by every coupled case (one with a [coupling] table); a case's own value replaces them.
# The coupling values are FemCouplingEngine's defaults, so a case states only what it chooses.
SHARED_DEFAULTS = {
    "coupling": {
        "average_forces": False,        # True: send the window average of the nodal forces (impulse-conserving)
        "contact_model": "facets",      # "facets" (YADE facets, the scene's contact law), "meshContacts"
                                        # (the engine's facet > edge > vertex contacts, Hertz-Mindlin) or
                                        # "polyhedra" (the surface joins a PolyhedraGpuEngine's walls)
        "implicit_tolerance": 1.0e-3,   # implicit scheme: rms position residual / rms interface displacement
        "implicit_max_iterations": 30,  # implicit scheme: passes per window before it is accepted unconverged
        "implicit_relaxation": 0.5,     # implicit scheme: first relaxation factor of a window
        "aitken": True,                 # implicit scheme: dynamic Aitken relaxation
    },
    "fem": {
        "fem_linear_solver": "mumps",   # FreeFEM's -linearSolver: "mumps" (MUMPS_seq) or "umfpack", which repeats a
                                        # run bit for bit (MUMPS_seq's automatic ordering varies from run to run, at
                                        # about 1e-9) for several times MUMPS's time a solve on 3D meshes
    },
    "output": {
        "progress_lines": 10,           # progress lines each solver prints over the run
        "snapshot_every_s": -1.0,       # simulated s between ParaView snapshots (fields.xdmf); 0: none; negative:
                                        # about 20 over a default run, none in a smoke run (railcosim/snapshots.py)
    },
}
# What a coupled case must state itself: there is no default a case could rely on.
REQUIRED = {"coupling": ("scheme", "fem_dt")}

# Rules for parameters that mean the same in every case (their meaning is fixed by the coupling engine or the
# FEM solver, not by the case). A case's [limits] entry for the same name replaces the rule here.
SHARED_LIMITS = {
    "duration_s": {"min_exclusive": 0, "min": "fem_dt"},  # at least one coupling window
    "average_s": {"min_exclusive": 0, "max": "duration_s"},
    "fem_dt": {"min_exclusive": 0},
    # FemCouplingEngine runs round(fem_dt/dem_dt) DEM steps per window at fem_dt/n: any other dem_dt would be
    # replaced silently, so the run would not use what parameters.json says.
    "dem_dt": {"min_exclusive": 0, "divides": "fem_dt"},
    # A fraction of YADE's P-wave step, the critical step estimate: above 1 only on purpose.
    "dem_dt_safety": {"min_exclusive": 0, "max": 1, "force": "force_dem_dt"},
    "scheme": {"choices": ["justInTime", "predictive", "implicit"]},
    # "hierarchy": the former name of "meshContacts", still accepted.
    "contact_model": {"choices": ["facets", "meshContacts", "hierarchy", "polyhedra"]},
    "restitution": {"min_exclusive": 0, "max": 1},  # 0 would make the Hertz-Mindlin damping log(0)
    "friction": {"min": 0},
    "local_damping": {"min": 0, "max_exclusive": 1},
    "sphere_radius": {"min_exclusive": 0},
    "particle_density": {"min_exclusive": 0},
    "particle_young": {"min_exclusive": 0},
    "seed": {},
    "implicit_tolerance": {"min_exclusive": 0},
    "implicit_max_iterations": {"min": 1},
    "implicit_relaxation": {"min_exclusive": 0, "max": 1},
    "progress_lines": {"min": 1},
    "snapshot_every_s": {"min": -1},
    "fem_linear_solver": {"choices": ["mumps", "umfpack"]},
}

RULE_KEYS = ("min", "min_exclusive", "max", "max_exclusive", "choices", "divides", "force")
SHARED_SOURCE = "shared rule in python/railcosim/parameters.py"
_COMPARISONS = {"min": (lambda v, b: v >= b, ">="), "min_exclusive": (lambda v, b: v > b, ">"),
                "max": (lambda v, b: v <= b, "<="), "max_exclusive": (lambda v, b: v < b, "<")}
# dem_dt divides fem_dt when their ratio is a whole number to this relative precision (decimal inputs such as
# 1e-5 / 2e-6 are not exact in binary).
DIVIDES_TOLERANCE = 1e-6


class ParameterError(Exception):
    """A parameter value or declaration that is refused before any solver starts."""


def nearest(name, names):
    """' (did you mean a, b?)' for a misspelt name, or '' when nothing is close."""
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def convert_like(key, text, default):
    """Converts a --set value to the type of the parameter's default, so typos fail loudly. A list parameter takes
    comma-separated values (brackets optional), each converted like the default's first element."""
    if isinstance(default, list):
        items = [item.strip() for item in text.strip().strip("[]").split(",") if item.strip()]
        return [convert_like(key, item, default[0]) for item in items] if default else items
    try:
        if isinstance(default, bool):
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
        return text
    except ValueError:
        raise ParameterError(f"--set {key}={text}: expected a {type(default).__name__} like the default {default!r}") from None


def case_defaults(config):
    """({name: default}, {name: table}) of every parameter of a case: its tables, and for a coupled case the
    shared defaults it does not set. Refuses what would silently lose a value: an unknown table (a misspelt
    [couplng]), a name in two tables, a table name used as a parameter name, a coupled case without a required key."""
    for key, value in config.items():
        if key not in PARAMETER_TABLES + OTHER_KEYS:
            raise ParameterError(f"case.toml: unknown entry '{key}'{nearest(key, PARAMETER_TABLES + OTHER_KEYS)}; "
                                 f"the tables of parameters are {', '.join(f'[{t}]' for t in PARAMETER_TABLES)}")
        if key in PARAMETER_TABLES + ("limits", "smoke") and not isinstance(value, dict):
            raise ParameterError(f"case.toml: '{key}' must be a table ([{key}]), got {value!r}")
    coupled = "coupling" in config
    defaults, tables = {}, {}
    for table in PARAMETER_TABLES:
        entries = dict(SHARED_DEFAULTS.get(table, {})) if coupled else {}
        entries.update(config.get(table, {}))
        for name, value in entries.items():
            if name in tables:
                raise ParameterError(f"case.toml: parameter '{name}' is in both [{tables[name]}] and [{table}]; "
                                     "a name must be unique across the tables")
            if name in PARAMETER_TABLES:
                raise ParameterError(f"case.toml [{table}]: '{name}' is the name of a table, not a parameter")
            defaults[name], tables[name] = value, table
    if coupled:
        for table, names in REQUIRED.items():
            for name in names:
                if tables.get(name) != table:
                    raise ParameterError(f"case.toml: a coupled case sets {name} in its [{table}] table (no shared default)")
    return defaults, tables


def parameter_name(key, tables, where):
    """The parameter a key names, NAME or TABLE.NAME; ParameterError naming `where` and the nearest names."""
    table, dot, name = key.rpartition(".")
    if dot and table in PARAMETER_TABLES:
        if tables.get(name) == table:
            return name
        known = [n for n, t in tables.items() if t == table]
        elsewhere = f" (it is in [{tables[name]}])" if name in tables else nearest(name, known)
        raise ParameterError(f"{where} unknown parameter '{key}': [{table}] has no '{name}'{elsewhere}")
    if key in tables:
        return key
    raise ParameterError(f"{where} unknown parameter '{key}'{nearest(key, list(tables))}; the parameters are those of the "
                         "case.toml tables " + ", ".join(f"[{t}]" for t in PARAMETER_TABLES if t in tables.values())
                         + (" and their shared defaults" if "coupling" in tables.values() else ""))


def _named_entries(entries, tables, where):
    """{parameter: value} of a [smoke] or [limits] table, whose keys are NAME or TABLE.NAME (TOML reads the
    dotted key coupling.fem_dt as a nested table {coupling: {fem_dt: ...}})."""
    named = {}
    for key, value in entries.items():
        if key in PARAMETER_TABLES and isinstance(value, dict):
            pairs = [(f"{key}.{name}", inner) for name, inner in value.items()]
        else:
            pairs = [(key, value)]
        for full_key, inner in pairs:
            named[parameter_name(full_key, tables, where)] = inner
    return named


def resolve_parameters(config, smoke, assignments):
    """The case's defaults (case_defaults), then its [smoke] table when smoke, then each KEY=VALUE of --set."""
    defaults, tables = case_defaults(config)
    params = dict(defaults)
    if smoke:
        params.update(_named_entries(config.get("smoke", {}), tables, "case.toml [smoke] sets"))
    for item in assignments:
        if "=" not in item:
            raise ParameterError(f"--set needs key=value, got '{item}'")
        key, text = item.split("=", 1)
        name = parameter_name(key, tables, "--set:")
        params[name] = convert_like(key, text, params[name])
    return params


def case_limits(config):
    """{name: (rule, source)} for every parameter of the case: its [limits] entry, else the shared rule.
    Refuses declarations that do not fit the parameters (a case author's typo must not disable a check)."""
    defaults, tables = case_defaults(config)
    declared = _named_entries(config.get("limits", {}), tables, "case.toml [limits] declares")
    for name, rule in declared.items():
        if not isinstance(rule, dict):
            raise ParameterError(f"case.toml [limits] {name}: expected a table such as {{min_exclusive = 0}}, got {rule!r}")
    limits = {}
    for name, default in defaults.items():
        if name in declared:
            limits[name] = (declared[name], "case.toml [limits]")
        elif name in SHARED_LIMITS:
            limits[name] = (SHARED_LIMITS[name], SHARED_SOURCE)
        elif not isinstance(default, bool):  # a boolean's type is its whole range
            raise ParameterError(f"case.toml: parameter '{name}' has no declared range; add it to [limits], "
                                 f"e.g. {name} = {{min_exclusive = 0}} (or {{}} for any {type(default).__name__})")
    for name, (rule, source) in limits.items():
        for key, bound in rule.items():
            if key not in RULE_KEYS:
                raise ParameterError(f"{source} {name}: unknown rule '{key}'{nearest(key, RULE_KEYS)}; "
                                     f"rules are {', '.join(RULE_KEYS)}")
            if key in ("divides", "force") or (key in _COMPARISONS and isinstance(bound, str)):
                if bound not in defaults:
                    raise ParameterError(f"{source} {name}: {key} names unknown parameter '{bound}'"
                                         f"{nearest(str(bound), list(defaults))}")
            elif key == "choices" and not isinstance(bound, list):
                raise ParameterError(f"{source} {name}: choices must be a list, got {bound!r}")
    return limits


def _type_problem(name, value, default):
    """Why value does not have the type of the default (int is accepted for a float), or None."""
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    else:
        ok = isinstance(value, type(default))
    if not ok:
        return f"{name}={value!r} is not a {type(default).__name__} like the default {default!r}"
    if isinstance(value, float) and not math.isfinite(value):
        return f"{name}={value} is not a finite number"
    return None


def _divides_problem(name, value, other, whole):
    ratio = whole / value
    steps = round(ratio)
    if steps >= 1 and abs(ratio - steps) <= DIVIDES_TOLERANCE * ratio:
        return None
    below = max(1, math.floor(ratio))
    choices = sorted({whole / below, whole / (below + 1)} if ratio > 1 else {whole})
    return (f"{name}={value:g} does not divide {other}={whole:g} into a whole number of steps (ratio {ratio:.4g}); "
            f"the run would use another step. Nearest: {' or '.join(f'{name}={c:.12g}' for c in choices)}")


def check_parameters(params, config, case=None):
    """Problems with the parameter values, one line each ([] when all are valid): types, non-finite numbers,
    [limits] / shared rules, then the case's own check_parameters(p) -> [message] (railcosim.case.Case)."""
    defaults, _ = case_defaults(config)
    limits = case_limits(config)
    problems, bad = [], set()
    for name, default in defaults.items():
        problem = _type_problem(name, params[name], default)
        if problem:
            problems.append(problem)
            bad.add(name)
    # Bounds that name another parameter are judged only once that parameter itself is valid: a bad fem_dt
    # should be reported as itself, not as a confusing duration_s bound.
    for referring in (False, True):
        for name, (rule, source) in limits.items():
            if name in bad:
                continue
            value = params[name]
            force = rule.get("force")
            forced = force is not None and params.get(force) is True
            problem = None
            for key, bound in rule.items():
                if key in _COMPARISONS:
                    if isinstance(bound, str) != referring or (forced and key.startswith("max")):
                        continue
                    limit = params[bound] if isinstance(bound, str) else bound
                    if isinstance(bound, str) and bound in bad:
                        continue
                    test, sign = _COMPARISONS[key]
                    if not test(value, limit):
                        shown = f"{bound} ({limit:g})" if isinstance(bound, str) else f"{limit:g}"
                        hint = f", unless --set {force}=true" if force and key.startswith("max") else ""
                        problem = f"{name}={value!r} is out of range: must be {sign} {shown} ({source}{hint})"
                elif key == "choices" and not referring and value not in bound:
                    problem = f"{name}={value!r} is not one of {', '.join(map(str, bound))}{nearest(str(value), list(map(str, bound)))} ({source})"
                elif key == "divides" and referring and bound not in bad:
                    problem = _divides_problem(name, value, bound, params[bound])
                if problem:
                    break
            if problem:
                problems.append(problem)
                bad.add(name)
    if not problems and case is not None:
        problems += list(case.check_parameters(params))
    return problems


def default_time_limit(config, params):
    """Wall-clock limit [s] of a run when --time-limit is not given: 20 times the case's expected_wall_s
    (the default run's measured wall time, in case.toml), scaled up when duration_s is longer than the default,
    and at least 600 s; 3600 s when the case declares no expected_wall_s."""
    expected = config.get("expected_wall_s")
    if expected is None:
        return 3600.0
    default_duration = case_defaults(config)[0].get("duration_s")
    scale = max(1.0, params["duration_s"] / default_duration) if default_duration and "duration_s" in params else 1.0
    return max(600.0, 20.0 * float(expected) * scale)
