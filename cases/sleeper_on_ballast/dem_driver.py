# DEM participant of the sleeper-on-ballast case without YADE (dem_driver = "standalone"): the same load run as dem.py,
# on the polyhedra library through its C interface (railcosim.polyhedra_driver), one coupling window per call as
# FemCouplingEngine with contactModel 'polyhedra' runs it; the GPU machine's path (no YADE there).
# Run by `railcosim run` as: python3 dem_driver.py PARAMETERS.json ENDPOINT OUTDIR (after bed.py, which leaves bed.json)
# With `--checkpoint-every S` the driver saves a restart checkpoint with the FEM side every S s of simulated time (the
# polyhedra system, the coupling and this script's time series); `--resume OUT` goes on from the newest one.
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(os.path.dirname(HERE)), "python")]
import driver_engine as de  # noqa: E402
import loadrun  # noqa: E402
import preparation as prep  # noqa: E402
from railcosim import dem as coupled_dem  # noqa: E402  (coupling options; YADE-free)
from railcosim import polyhedra_driver, results, solvers  # noqa: E402

p, endpoint, out = coupled_dem.participant_arguments()
scene, bed_record, bed, attrs = loadrun.prepared_bed(p, out)
duration = p["duration_s"]

# 1.-2. The box and the prepared bed: stones and the five sensor blocks (dem.py's scene, loadrun's walls).
seat = float(attrs["seat_height_m"])
engine = de.polyhedra_bed(scene, bed, p, 1e-6)
corners = loadrun.wall_corners(scene, seat)
engine.set_walls(corners, np.zeros(len(corners), np.int32), [prep.stone_material(scene)[1]])
stones = np.flatnonzero(bed.kind == prep.STONE)
# 3. Time step, before the surface joins the walls (as dem.py's probe engine).
engine.dt, critical, design = loadrun.time_step(p, scene, engine.critical_time_step)
# 4. Couple: the sleeper's bottom face joins the walls; each window is one batch. A resumed run goes on from the
# checkpoint's state (the system, the scheme, the driver's counters) instead of the bed's.
options = coupled_dem.coupling_options(p)
restart = polyhedra_driver.restart_settings()
if restart:
    engine.set_restart(**restart)
subcycles = engine.connect(endpoint, scheme=options["scheme"], surface_material=loadrun.sleeper_material(p),
                           timeout=options["timeout"], subcycles=options.get("subcycles", 0),
                           implicit_tolerance=options["implicitTolerance"],
                           implicit_max_iterations=options["implicitMaxIterations"],
                           implicit_relaxation=options["implicitRelaxation"], aitken=options["aitken"])
figures = engine.figures()
windows = int(round(duration / figures["window_length"]))
mass = float(np.sum(engine.states()[4][stones]))
backend, reason = engine.backend
sensors = loadrun.Sensors(p, scene, bed)
print(f"{len(stones)} stones ({mass:.1f} kg) and {len(sensors.indices)} sensors from {bed_record['path']}; sleeper "
      f"bottom at z = {seat:.4f} m; dt {engine.dt:.3e} s = {engine.dt / critical:.3f} x the critical step "
      f"{critical:.3e} s (contacts of {design['contact_force_n']:.0f} N, impacts at {design['impact_speed_m_s']:g} m/s); "
      f"{backend} ({reason})", flush=True)
print(f"coupled: dt={engine.dt:.3e} s, {subcycles} DEM steps per FEM step, {windows} windows ({options['scheme']}, "
      f"{int(figures['surface_triangles'])} surface triangles, polyhedra contacts, standalone driver)", flush=True)


class Window:
    """What loadrun.Sensors reads of a window, from the driver."""

    def frames(self, indices):
        return engine.states(indices)[:2]

    def contacts(self):
        return engine.contacts(sensors.indices)  # the sensors' alone: Sensors.top_forces reads no other

    @property
    def interface_force(self):
        return [figures[f"total_force_{k}"] for k in "xyz"]

    @property
    def surface_force(self):
        return [figures[f"surface_force_{k}"] for k in "xyz"]


window = Window()
every = solvers.progress_period({**p, "duration_s": duration})
recorder, first, _ = polyhedra_driver.window_recorder(engine, out, restart)  # resumed: appends to the checkpoint's
wall_start = time.monotonic()
script_time = 0.0  # this script's own share of each window: sensor readings, time series, checkpoints' files
for w in range(first, windows):
    engine.window()
    window_done = time.monotonic()
    figures = engine.figures()
    recorder.append(time=figures["time"], **sensors.record(window, w + 1), interface_work_dem=figures["interface_work_dem"],
                    interface_work_fem=figures["interface_work_fem"])
    polyhedra_driver.complete_pending_checkpoint(engine, recorder, w + 1)
    if (w + 1) % every == 0:
        print(f"t={figures['time']:.4f} s  window {w + 1}/{windows}  sleeper carried "
              f"{figures['total_force_z'] / 1e3:.2f} kN  {time.monotonic() - wall_start:.1f} s", flush=True)
    script_time += time.monotonic() - window_done
engine.finalize()
wall_time = time.monotonic() - wall_start
# 5. What the post-processing reads (dem_info.json): dem.py's fields, the coupling figures under FemCouplingEngine's names.
info = {**engine.coupling_info(options["scheme"]), "steps": windows * subcycles, "dt": engine.dt,
        "wall_time_s": wall_time,
        "particles": len(stones), "stones": len(stones), "sensors": len(sensors.indices), "particle_mass_kg": mass,
        "critical_time_step_s": critical, "design_contact_force_n": design["contact_force_n"], "seat_height_m": seat,
        "sensor_period_windows": sensors.every, "polyhedra_backend": backend, "dem_driver": de.DRIVER,
        "polyhedra_time_s": figures["polyhedra_time"], "script_time_s": script_time, "bed": bed_record}
results.save_dem_outputs(out, recorder, info)
print(f"done: {windows * subcycles} steps in {wall_time:.1f} s; DEM {figures['polyhedra_time']:.1f} s, FEM wait "
      f"{figures['wait_time']:.1f} s, bridge {figures['bridge_time']:.3f} s over {int(figures['windows'])} exchanges, "
      f"script {script_time:.1f} s",
      flush=True)
