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

Nothing here imports YADE at module level, so the runner side can read the engine options without it.
"""
import json
import sys
import time

from railcosim import results, snapshots, solvers

# Longest wait for any message of the FEM participant [s] (FemCouplingEngine.timeout): the FEM side's
# factorisation of the largest case takes a few seconds, a lost peer is reported by the bridge sooner.
COUPLING_TIMEOUT_S = 60.0
# The name under which the per-window callback is reachable from a PyRunner command (run in YADE's __main__).
WINDOW_CALLBACK = "railcosim_record_window"


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


class CoupledDem:
    """Set-up and tail of a case's YADE participant: parameters, coupling engine, time step, the window loop
    with its recorder, and the files the post-processing reads."""

    def __init__(self, argv=None):
        argv = sys.argv if argv is None else argv
        if len(argv) != 4:
            raise SystemExit(f"usage: railcosim yade {argv[0]} PARAMETERS.json ENDPOINT OUTDIR (started by railcosim run)")
        parameters_path, self.endpoint, self.out = argv[1:]
        with open(parameters_path) as f:
            self.parameters = json.load(f)
        self.coupling = None
        self.recorder = None
        self.snapshots = None
        self.windows = None
        self.time_origin = 0.0
        self.wall_time_s = None

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
                                          **{**coupling_options(self.parameters), **overrides})
        return self.coupling

    def connect(self):
        """Handshake with the FEM participant: receives the surface (facets or mesh contacts), sets O.dt to
        fem_dt / subcycles; duration_s fixes the number of windows, recorded on the FEM clock (t = 0 here)."""
        from yade import O
        self.coupling.connect()
        self.windows = int(round(self.parameters["duration_s"] / self.coupling.femDt))
        self.time_origin = O.time
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
        self.recorder = results.DemRecorder(self.out)  # dem_timeseries.h5, written as the run goes
        snapshot_every = snapshots.snapshot_windows(self.parameters)
        polyhedra = [e for e in O.engines if isinstance(e, getattr(wrapper, "PolyhedraGpuEngine", ()))]
        self.snapshots = (snapshots.DemSnapshots(self.out, coupling, polyhedra[0] if polyhedra else None)
                          if snapshot_every else None)
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

        import __main__
        setattr(__main__, WINDOW_CALLBACK, record_window)
        # Counted from now: a scene that ran before connecting (a deposition, say) would fire it at once otherwise.
        O.engines = O.engines + [wrapper.PyRunner(command=f"{WINDOW_CALLBACK}()", iterPeriod=coupling.subcycles,
                                                  initRun=False, iterLast=O.iter)]
        O.run(self.windows * coupling.subcycles + 1, True)
        coupling.finalize()
        if self.snapshots:
            self.snapshots.close()
        self.wall_time_s = time.monotonic() - wall_start

    def save(self, arrays=None, **info):
        """Writes dem_timeseries.h5 (closed, with `arrays`: per-run data such as the surface triangles) and
        dem_info.json: the engine's figures (results.coupling_info), steps, step, wall time and `info`."""
        from yade import O
        coupling = self.coupling
        info = {**results.coupling_info(coupling), "steps": O.iter, "dt": O.dt, "wall_time_s": self.wall_time_s, **info}
        results.save_dem_outputs(self.out, self.recorder, info, **(arrays or {}))
        print(f"done: {O.iter} steps in {self.wall_time_s:.1f} s; bridge {coupling.bridgeTime:.3f} s over "
              f"{coupling.exchanges} exchanges", flush=True)
