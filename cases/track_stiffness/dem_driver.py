# DEM participant of the track cases without YADE (dem_driver = "standalone"): dem.py's coupled run on the polyhedra
# library through its C interface (railcosim.track_driver, railcosim.polyhedra_driver): the packed bed on the base
# wall between the mirror walls, the sleepers' bases from FreeFEM (freefem_scripts/examples/track.edp) as the coupled
# surface; one coupling window per call; the same records and files as dem.py. The GPU machine's path (no YADE there).
# Run by `railcosim run` as: python3 dem_driver.py PARAMETERS.json ENDPOINT OUTDIR (after bed.py, which packed the bed)
# With `--checkpoint-every S` the driver saves a restart checkpoint with the FEM side every S s of simulated time;
# `--resume OUT` goes on from the newest one.
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [os.path.join(ROOT, "python"), os.path.join(ROOT, "yade_engines", "clusters")]
from railcosim import dem as coupled_dem  # noqa: E402  (coupling options; YADE-free)
from railcosim import polyhedra_driver, results, solvers, track_driver  # noqa: E402

p, endpoint, out = coupled_dem.participant_arguments()

# 1-2. The packed bed (bed.py packed it into the cache) on the base wall between the mirror walls, the test's materials.
bed, base_z, cache = track_driver.packed_bed(p, out)
stage = track_driver.coupled_scene(p, bed, base_z)
engine = stage.bed
material, _ = track_driver.materials(p)
_, _, _, masses = stage.spheres()
bed_mass = float(masses.sum())
# 3. Couple: the sleepers' bases join the walls with the sleepers' material; each window is one batch of steps, the
# step dem_dt_safety times the P-wave step (dem.py's rule), fitted to fem_dt / subcycles. A resumed run goes on from
# the checkpoint's state.
options = coupled_dem.coupling_options(p)
restart = polyhedra_driver.restart_settings()
if restart:
    engine.set_restart(**restart)
subcycles = engine.connect(endpoint, scheme=options["scheme"], surface_material=material["sleeper"],
                           timeout=options["timeout"], subcycles=options.get("subcycles", 0),
                           implicit_tolerance=options["implicitTolerance"],
                           implicit_max_iterations=options["implicitMaxIterations"],
                           implicit_relaxation=options["implicitRelaxation"], aitken=options["aitken"])
figures = engine.figures()
windows = int(round(p["duration_s"] / figures["window_length"]))
backend, reason = engine.backend
print(f"{len(bed)} spheres, {bed_mass:.1f} kg, base at z = {base_z:.4f} m ({p['subgrade']}); bed {cache}; {backend} "
      f"({reason})", flush=True)
print(f"coupled: dt={engine.dt:.3e} s, {subcycles} DEM steps per FEM step, {windows} windows ({options['scheme']}, "
      f"{int(figures['surface_triangles'])} surface triangles, polyhedra contacts, standalone driver)", flush=True)

# 4. The windows, one record each, dem.py's: the force on the sleepers (total and nodal), on the base, kinetic energy.
every = solvers.progress_period(p)
recorder, first, _ = polyhedra_driver.window_recorder(engine, out, restart)  # resumed: appends to the checkpoint's
wall_start = time.monotonic()
for w in range(first, windows):
    engine.window()
    figures = engine.figures()
    _, nodal = engine.surface_state()
    recorder.append(time=figures["time"], interface_force=[figures[f"total_force_{k}"] for k in "xyz"],
                    base_force=-float(stage.force("base")[2]), kinetic_energy=stage.kinetic_energy(),
                    nodal_forces=nodal, interface_work_dem=figures["interface_work_dem"],
                    interface_work_fem=figures["interface_work_fem"])
    polyhedra_driver.complete_pending_checkpoint(engine, recorder, w + 1)
    if (w + 1) % every == 0:
        last = recorder.last
        print(f"t={figures['time']:.4f} s  window {w + 1}/{windows}  interface Fz={last['interface_force'][2]:.0f} N  "
              f"base wall {last['base_force']:.0f} N  kinetic energy {last['kinetic_energy']:.3e} J  "
              f"{time.monotonic() - wall_start:.1f} s", flush=True)
positions, _ = engine.surface_state()
triangles = engine.surface_triangles()
engine.finalize()
wall_time = time.monotonic() - wall_start
# 5. What the post-processing reads (dem_info.json): dem.py's fields, the coupling figures under FemCouplingEngine's
# names; the interface nodes' positions and triangles.
info = {**engine.coupling_info(options["scheme"]), "steps": windows * subcycles, "dt": engine.dt,
        "wall_time_s": wall_time, "particles": len(bed), "total_particle_mass_kg": bed_mass, "base_z": base_z,
        "packed_bed": cache, "polyhedra_backend": backend, "dem_driver": "standalone",
        "polyhedra_time_s": figures["polyhedra_time"]}
results.save_dem_outputs(out, recorder, info, node_positions=positions, triangles=triangles)
print(f"done: {windows * subcycles} steps in {wall_time:.1f} s; DEM {figures['polyhedra_time']:.1f} s, FEM wait "
      f"{figures['wait_time']:.1f} s, bridge {figures['bridge_time']:.3f} s over {int(figures['windows'])} exchanges",
      flush=True)
