"""The YADE participant of a coupled case: what every case's dem.py does around its own physics.

A case's dem.py runs inside YADE (`railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR`, started by the
runner) and reads as its numbered physics steps around these calls:

    dem = CoupledDem()                                   # the run's parameters, endpoint and results folder
    p = dem.parameters
    # 1. materials, bodies ...
    coupling = dem.coupling_engine(material=...)         # FemCouplingEngine with the [coupling] keys
    O.engines = [..., coupling, NewtonIntegrator(...)]   # after the contact loop, before the integrator
    O.dt = dem.time_step()                               # dem_dt, or dem_dt_safety x YADE's P-wave step
    dem.connect()                                        # handshake: the surface arrives, O.dt = fem_dt / subcycles
    dem.run(record)                                      # duration_s of windows, record() once per window
    dem.save(particles=...)                              # dem_timeseries.h5 and dem_info.json

Restart checkpoints need nothing of the case: `railcosim run --checkpoint-every S` and `--resume DIR` set the
environment (RESTART_ENVIRONMENT) that coupling_engine() hands to FemCouplingEngine; run() completes each checkpoint
the engine orders (the scene, every engine's and material's attributes, engines' private state, this object's clock,
the time series so far, `dem.state`) and, in a resumed run, puts all of it back before the first step. A case's dem.py must build the
same scene again and keep whatever it accumulates during the run in the scene, its engines or `dem.state` (a dict of
picklable values), not in Python variables that a resumed run would start afresh.

Nothing here imports YADE at module level, so the runner side can read the engine options without it.
"""
import json
import os
import pickle
import sys
import time

from railcosim import results, snapshots, solvers

# Longest wait for any message of the FEM participant [s] (FemCouplingEngine.timeout): the FEM side's
# factorisation of the largest case takes a few seconds, a lost peer is reported by the bridge sooner.
COUPLING_TIMEOUT_S = 60.0
# The name under which the per-window callback is reachable from a PyRunner command (run in YADE's __main__).
WINDOW_CALLBACK = "railcosim_record_window"
# Restart settings from `railcosim run` (the FEM side's plugin reads the same variables): FemCouplingEngine attribute
# for each environment variable.
RESTART_ENVIRONMENT = {"RAILCOSIM_CHECKPOINT_EVERY": "checkpointEvery", "RAILCOSIM_CHECKPOINT_DIR": "checkpointFolder",
                       "RAILCOSIM_CHECKPOINT_RUN": "checkpointRun", "RAILCOSIM_RESUME": "resumeFrom"}
# Engines whose whole state their own restart code restores (FemCouplingEngine: connect() and restoreCheckpoint()).
SELF_RESTORING_ENGINES = ("FemCouplingEngine",)
# Runs up to this many steps are stepped with O.step(): O.run(n, True) waits by polling every 40 ms (YADE's
# yadeWrapper.cpp wait()), which costs more than the steps themselves when a script runs many short chunks.
STEPPED_RUN_MAX = 10000


def run_steps(steps):
    """Advances YADE's scene to O.iter + steps (not at all for steps <= 0), as O.run(steps, True) does but without its
    40 ms polling for short runs: O.step() runs the same engines in the same order."""
    from yade import O
    if steps > STEPPED_RUN_MAX:
        O.run(steps, True)
        return
    # Up to an iteration, as O.run: a repeated implicit coupling pass sets O.iter back to its window's start.
    end = O.iter + steps
    while O.iter < end:
        O.step()


def coupling_options(p):
    """FemCouplingEngine keyword arguments from a case's [coupling] parameters: scheme, force averaging,
    contact model, the implicit scheme's settings, and the DEM steps per window when dem_dt is given (else
    the engine fits them to O.dt at connection)."""
    options = {"scheme": p["scheme"], "averageForces": p["average_forces"],
               "contactModel": p["contact_model"], "timeout": COUPLING_TIMEOUT_S,
               "label": "coupling", "implicitTolerance": float(p["implicit_tolerance"]),
               "implicitMaxIterations": int(p["implicit_max_iterations"]),
               "implicitRelaxation": float(p["implicit_relaxation"]), "aitken": bool(p["aitken"])}
    if "dem_dt" in p:
        options["subcycles"] = int(round(p["fem_dt"] / p["dem_dt"]))
    return options


def restart_options(environment=None):
    """FemCouplingEngine's restart attributes from the environment `railcosim run` sets (RESTART_ENVIRONMENT)."""
    environment = os.environ if environment is None else environment
    options = {}
    for variable, attribute in RESTART_ENVIRONMENT.items():
        value = environment.get(variable, "")
        if value:
            options[attribute] = float(value) if attribute == "checkpointEvery" else value
    return options


def _plain(value):
    """Whether an attribute value is data (numbers, text, vectors, lists of them), as opposed to a YADE object."""
    from yade.wrapper import Serializable
    if isinstance(value, Serializable):
        return False
    if isinstance(value, (list, tuple)):
        return all(_plain(v) for v in value)
    return True


# Nesting followed into attributes that are YADE objects (engine > dispatcher > functor is 3): deep enough for every
# engine, and a bound for an object that refers back to one that holds it.
ATTRIBUTE_DEPTH = 6


def _attributes(obj, depth=0):
    """{name: value} of a YADE object's attributes, nested objects (functors, dispatchers) by value; values that do
    not pickle (enumerations: settings, not state) are left out."""
    from yade.wrapper import Serializable
    state = {}
    for name, value in obj.dict().items():
        if isinstance(value, Serializable):
            if depth < ATTRIBUTE_DEPTH:
                state[name] = ("object", type(value).__name__, _attributes(value, depth + 1))
        elif isinstance(value, (list, tuple)) and value and all(isinstance(v, Serializable) for v in value):
            if depth < ATTRIBUTE_DEPTH:
                state[name] = ("objects", [(type(v).__name__, _attributes(v, depth + 1)) for v in value])
        elif _plain(value):
            try:
                pickle.dumps(value)
            except Exception:
                continue
            state[name] = ("value", value)
    return state


def _restore_attributes(obj, state, where):
    """Sets the attributes of a live YADE object that differ from `state` (_attributes of the saved one)."""
    changed = {}
    for name, (kind, *saved) in state.items():
        if kind == "value":
            if getattr(obj, name) != saved[0]:
                changed[name] = saved[0]
        elif kind == "object":
            live = getattr(obj, name)
            if live is not None and type(live).__name__ == saved[0]:
                _restore_attributes(live, saved[1], f"{where}.{name}")
        else:
            live = getattr(obj, name)
            if len(live) != len(saved[0]):
                raise RuntimeError(f"restart: {where}.{name} has {len(live)} entries, the checkpoint {len(saved[0])}; "
                                   "resume with the case and parameters of the interrupted run")
            for k, (item, (class_name, attributes)) in enumerate(zip(live, saved[0])):
                if type(item).__name__ == class_name:
                    _restore_attributes(item, attributes, f"{where}.{name}[{k}]")
    if changed:
        obj.updateAttrs(changed)


def engine_states(engines):
    """What a restart checkpoint keeps of each engine: its class, its attributes (nested objects by value) and, for
    an engine with private state (a method restartState()), that state."""
    states = []
    for engine in engines:
        name = type(engine).__name__
        if name in SELF_RESTORING_ENGINES:
            states.append((name, None, None))
            continue
        private = engine.restartState() if hasattr(engine, "restartState") else None
        states.append((name, _attributes(engine), private))
    return states


def restore_engine_states(engines, states):
    """Puts engine_states() back into the engines of a rebuilt scene (the same engines, in the same order)."""
    if [type(e).__name__ for e in engines] != [name for name, _, _ in states]:
        raise RuntimeError("restart: the scene's engines are " + ", ".join(type(e).__name__ for e in engines) +
                           "; the checkpoint's were " + ", ".join(name for name, _, _ in states) +
                           "; resume with the case and parameters of the interrupted run")
    for k, (engine, (name, attributes, private)) in enumerate(zip(engines, states)):
        if attributes is None:
            continue
        _restore_attributes(engine, attributes, f"O.engines[{k}] ({name})")
        if private is not None:
            engine.restoreRestartState(private)


def hertz_mindlin_contacts(restitution, walls=False):
    """YADE's engines up to the contact loop for spheres among themselves and on facets (and on walls, with `walls`):
    Hertz-Mindlin contacts damped by the restitution coefficient (Thornton 2013). A case appends its coupling engine
    and integrator."""
    from yade.wrapper import (Bo1_Facet_Aabb, Bo1_Sphere_Aabb, Bo1_Wall_Aabb, ForceResetter, Ig2_Facet_Sphere_ScGeom,
                              Ig2_Sphere_Sphere_ScGeom, Ig2_Wall_Sphere_ScGeom, InsertionSortCollider, InteractionLoop,
                              Ip2_FrictMat_FrictMat_MindlinPhys, Law2_ScGeom_MindlinPhys_Mindlin, MatchMaker)
    bounds = [Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()] + ([Bo1_Wall_Aabb()] if walls else [])
    geometries = [Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()] + ([Ig2_Wall_Sphere_ScGeom()] if walls else [])
    damping = dict(en=MatchMaker(algo="val", val=restitution), es=MatchMaker(algo="val", val=restitution))
    return [ForceResetter(), InsertionSortCollider(bounds),
            InteractionLoop(geometries, [Ip2_FrictMat_FrictMat_MindlinPhys(**damping)], [Law2_ScGeom_MindlinPhys_Mindlin()])]


def participant_arguments(argv=None):
    """(parameters, endpoint, results folder) from the command line `railcosim run` gives dem.py."""
    argv = sys.argv if argv is None else argv
    if len(argv) != 4:
        raise SystemExit(f"usage: {argv[0]} PARAMETERS.json ENDPOINT OUTDIR (a DEM participant started by railcosim run)")
    parameters_path, endpoint, out = argv[1:]
    with open(parameters_path) as f:
        return json.load(f), endpoint, out


class CoupledDem:
    """Set-up and tail of a case's YADE participant: parameters, coupling engine, time step, the window loop
    with its recorder, and the files the post-processing reads."""

    def __init__(self, argv=None):
        self.parameters, self.endpoint, self.out = participant_arguments(argv)
        self.coupling = None
        self.recorder = None
        self.snapshots = None
        self.windows = None
        self.time_origin = 0.0
        self.first_iter = 0
        self.wall_time_s = None
        self.state = {}  # the case's own run state (counters, sums ...): restart checkpoints keep it

    def time_step(self):
        """The DEM step asked for: dem_dt, else dem_dt_safety times YADE's P-wave step of the bodies so far
        (the connection then fits it to fem_dt / subcycles)."""
        p = self.parameters
        if "dem_dt" in p:
            return p["dem_dt"]
        from yade import utils
        return p["dem_dt_safety"] * utils.PWaveTimeStep()

    def coupling_engine(self, material, **overrides):
        """FemCouplingEngine on the run's endpoint with the [coupling] options (coupling_options); `material`
        is the surface's, `overrides` any further engine attributes (e.g. restitution)."""
        from yade.wrapper import FemCouplingEngine
        self.coupling = FemCouplingEngine(endpoint=self.endpoint, material=material,
                                          **{**coupling_options(self.parameters), **restart_options(), **overrides})
        return self.coupling

    @property
    def resuming(self):
        """Whether this run resumes from a restart checkpoint (railcosim run --resume)."""
        return bool(self.coupling and self.coupling.resumeFrom)

    def connect(self):
        """Handshake with the FEM participant: receives the surface (facets or mesh contacts), sets O.dt to
        fem_dt / subcycles; duration_s fixes the number of windows, recorded on the FEM clock (t = 0 here)."""
        from yade import O
        self.coupling.connect()
        self.windows = int(round(self.parameters["duration_s"] / self.coupling.femDt))
        self.time_origin, self.first_iter = O.time, O.iter  # a resumed run takes them from its checkpoint in run()
        print(f"coupled: O.dt={O.dt:.3e} s, {self.coupling.subcycles} DEM steps per FEM step, {self.windows} windows "
              f"({self.coupling.scheme}, {len(self.coupling.triangles)} surface triangles, "
              f"{self.parameters['contact_model']} contacts)", flush=True)

    @property
    def time(self):
        """Time since the handshake [s], the clock of the FEM side and of every record."""
        from yade import O
        return O.time - self.time_origin

    @property
    def last(self):
        """{series: value} of the latest window recorded."""
        return self.recorder.last

    def run(self, record, progress=None):
        """Runs the windows (one more DEM step so that the last window's forces are exchanged at its end), then
        tells the FEM side the run is over. After each window, record() returns {series: value} for
        dem_timeseries.h5 (time and the interface work of both sides are added); progress(last), if given,
        adds the case's figures to the progress_lines lines printed over the run."""
        from yade import O, wrapper
        coupling = self.coupling
        every = solvers.progress_period(self.parameters)
        snapshot_every = snapshots.snapshot_windows(self.parameters)
        polyhedra = [e for e in O.engines if isinstance(e, getattr(wrapper, "PolyhedraGpuEngine", ()))]
        self.snapshots = (snapshots.DemSnapshots(self.out, coupling, polyhedra[0] if polyhedra else None,
                                                 append=self.resuming) if snapshot_every else None)
        wall_start = time.monotonic()

        def record_window():
            self.recorder.append(time=self.time, **record(), interface_work_dem=coupling.interfaceWorkDem,
                                 interface_work_fem=coupling.interfaceWorkFem)
            if self.snapshots and coupling.window % snapshot_every == 0:
                self.snapshots.write(coupling.window // snapshot_every, self.time)
            if len(self.recorder) % every == 0:
                figures = f"  {progress(self.recorder.last)}" if progress else ""
                print(f"t={self.time:.4f} s  window {coupling.window}/{self.windows}{figures}  "
                      f"{time.monotonic() - wall_start:.1f} s", flush=True)
            if coupling.checkpointPending:
                self._complete_checkpoint()

        import __main__
        setattr(__main__, WINDOW_CALLBACK, record_window)
        # The recorder runs last in the step: it records the window and completes a checkpoint ordered at its exchange.
        # Counted from now: a scene that ran before connecting (a deposition, say) would fire it at once otherwise.
        O.engines = O.engines + [wrapper.PyRunner(command=f"{WINDOW_CALLBACK}()", iterPeriod=coupling.subcycles,
                                                  initRun=False, iterLast=O.iter)]
        if coupling.checkpointEvery > 0:
            # An engine that cannot checkpoint its state says so now rather than at the first checkpoint.
            for engine in O.engines:
                if hasattr(engine, "restartState"):
                    engine.restartState()
        if self.resuming:
            self._resume()
        else:
            self.recorder = results.DemRecorder(self.out)  # dem_timeseries.h5, written as the run goes
        last_iter = self.first_iter + self.windows * coupling.subcycles + 1
        if last_iter > O.iter:  # O.run(0) would run on without end; a run resumed at its last window has no step left
            O.run(last_iter - O.iter, True)
        coupling.finalize()
        if self.snapshots:
            self.snapshots.close()
        self.wall_time_s = time.monotonic() - wall_start

    def _complete_checkpoint(self):
        """From the recorder, the last engine of the step: the rest of the restart checkpoint ordered at this step's
        exchange (FemCouplingEngine.completeCheckpoint)."""
        from yade import O
        self.recorder.flush()
        state = {"engines": engine_states(O.engines), "materials": [_attributes(m) for m in O.materials],
                 "time_origin": self.time_origin, "first_iter": self.first_iter,
                 "windows_recorded": len(self.recorder), "case": self.state}
        folder = self.coupling.completeCheckpoint([self.recorder.path], pickle.dumps(state))
        print(f"checkpoint {folder} at t={self.time:.4f} s, window {self.coupling.window}", flush=True)

    def _resume(self):
        """The scene, the engines, the clock and the time series as the checkpoint holds them; the next step is the
        one after the step that wrote it."""
        from yade import O
        state = pickle.loads(self.coupling.restoreCheckpoint())
        restore_engine_states(O.engines, state["engines"])
        if len(O.materials) != len(state["materials"]):
            raise RuntimeError(f"restart: the scene has {len(O.materials)} materials, the checkpoint "
                               f"{len(state['materials'])}; resume with the case and parameters of the interrupted run")
        for k, (material, attributes) in enumerate(zip(O.materials, state["materials"])):
            _restore_attributes(material, attributes, f"O.materials[{k}]")  # a script may change them during a run
        self.time_origin, self.first_iter = state["time_origin"], state["first_iter"]
        self.state.clear()
        self.state.update(state["case"])
        self.recorder = results.DemRecorder(self.out, resume_windows=state["windows_recorded"])
        print(f"resumed from {self.coupling.resumeFrom} at t={self.time:.4f} s, window {self.coupling.window}, "
              f"step {O.iter}", flush=True)

    def save(self, arrays=None, **info):
        """Writes dem_timeseries.h5 (closed, with `arrays`: per-run data such as the surface triangles) and
        dem_info.json: the engine's figures (results.coupling_info), steps, step, wall time and `info`."""
        from yade import O
        coupling = self.coupling
        info = {**results.coupling_info(coupling), "steps": O.iter, "dt": O.dt, "wall_time_s": self.wall_time_s, **info}
        results.save_dem_outputs(self.out, self.recorder, info, **(arrays or {}))
        print(f"done: {O.iter} steps in {self.wall_time_s:.1f} s; bridge {coupling.bridgeTime:.3f} s over "
              f"{coupling.exchanges} exchanges", flush=True)


class StandaloneDem:
    """The YADE participant of a DEM-only case (case.toml `dem_only = true`: a bulk test of the particles, no structure):
    parameters and results folder, runs of the scene with a per-period recorder, and the files the post-processing
    reads (dem_timeseries.h5, dem_info.json). A dem.py reads as its physics:

        dem = StandaloneDem()
        p = dem.parameters
        # 1. materials, bodies, engines; O.dt
        dem.run(seconds, record, every_s)    # record() -> {series: value} every every_s of simulated time; may be
        dem.run(seconds, record, every_s)    # called again (phases of a test); the series go on
        dem.save(arrays={...}, **info)
    """

    def __init__(self, argv=None):
        self.parameters, _, self.out = participant_arguments(argv)
        self.recorder = None
        self.wall_time_s = 0.0
        self.state = {}

    @property
    def last(self):
        """{series: value} of the latest record."""
        return self.recorder.last

    def run(self, seconds, record, every_s, progress=None):
        """Runs the scene for `seconds` of simulated time (whole steps of O.dt), calling record() every `every_s`
        (and at the end) for dem_timeseries.h5 (time is added); progress(last), if given, adds the case's figures to
        the progress_lines lines printed over the run (progress_lines defaults to 10)."""
        from yade import O
        if self.recorder is None:
            self.recorder = results.DemRecorder(self.out)
        steps = max(1, int(round(seconds / O.dt)))
        records = max(1, int(round(seconds / every_s)))  # records spread evenly over the steps
        lines = max(1, self.parameters.get("progress_lines", 10))
        start = time.monotonic()
        done = 0
        for k in range(1, records + 1):
            chunk = int(round(k * steps / records)) - done
            if chunk > 0:
                O.run(chunk, True)
                done += chunk
            self.recorder.append(time=O.time, **record())
            if k * lines // records != (k - 1) * lines // records or k == records:
                figures = f"  {progress(self.recorder.last)}" if progress else ""
                print(f"t={O.time:.4f} s  step {O.iter}{figures}  {time.monotonic() - start:.1f} s", flush=True)
        self.wall_time_s += time.monotonic() - start

    def save(self, arrays=None, **info):
        """Writes dem_timeseries.h5 (closed, with `arrays`: per-run data such as final positions) and dem_info.json:
        steps, step, wall time and `info`."""
        from yade import O
        if self.recorder is None:
            self.recorder = results.DemRecorder(self.out)
        info = {"steps": O.iter, "dt": O.dt, "wall_time_s": self.wall_time_s, **info}
        results.save_dem_outputs(self.out, self.recorder, info, **(arrays or {}))
        print(f"done: {O.iter} steps in {self.wall_time_s:.1f} s", flush=True)
