# DEM participant of the block case: a bed of spheres settles in a box, then carries the coupled block.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import json
import math
import os
import random
import sys
import time

import numpy as np

import railcosim_results as results

params_path, endpoint, out = sys.argv[1], sys.argv[2], sys.argv[3]
with open(params_path) as f:
    p = json.load(f)
L, W, R = p["block_length"], p["block_width"], p["sphere_radius"]

# 1. Materials and a box: frictionless side walls at the block's footprint, a floor below the bed.
particle_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                           frictionAngle=math.atan(p["friction"])))
wall_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                       frictionAngle=0.0))
block_mat = O.materials.append(FrictMat(young=p["block_young"], poisson=p["block_poisson"], density=p["block_density"],
                                        frictionAngle=math.atan(p["friction"])))
walls = [O.bodies.append(utils.wall(position=pos, axis=axis, sense=sense, material=wall_mat))
         for axis, pos, sense in ((0, 0.0, 1), (0, L, -1), (1, 0.0, 1), (1, W, -1))]
floor = O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=wall_mat))

# 2. Staggered, jittered layers of spheres above the floor (z > 0 for now; moved below the block later).
rng = random.Random(p["seed"])
spacing = 2.0 * R * 1.05
spheres = []
for layer in range(p["bed_layers"]):
    shift = 0.5 * spacing * (layer % 2)
    x = R * 1.01 + shift
    while x <= L - R * 1.01:
        y = R * 1.01 + shift
        while y <= W - R * 1.01:
            centre = (x + rng.uniform(-0.05, 0.05) * R, y + rng.uniform(-0.05, 0.05) * R,
                      R * 1.02 + layer * spacing * math.sqrt(0.5))
            spheres.append(O.bodies.append(utils.sphere(centre, R, material=particle_mat)))
            y += spacing
        x += spacing

mindlin = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=p["restitution"]),
                                            es=MatchMaker(algo="val", val=p["restitution"]))
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                             [mindlin], [Law2_ScGeom_MindlinPhys_Mindlin()]),
             NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81))]
O.dt = p["dem_dt_safety"] * PWaveTimeStep()
settle_start = time.monotonic()
O.run(int(p["settle_s"] / O.dt), True)
bed_top = max(O.bodies[i].state.pos[2] for i in spheres) + R
print(f"{len(spheres)} spheres settled in {time.monotonic() - settle_start:.1f} s; bed top at {bed_top:.4f} m, "
      f"kinetic energy {utils.kineticEnergy():.2e} J", flush=True)

# 3. Move the bed so that its top lies just below the block's bottom face (z = 0 in the FEM frame).
gap = 1e-4
for i in spheres + [floor]:
    O.bodies[i].state.pos = O.bodies[i].state.pos - Vector3(0, 0, bed_top + gap)
    O.bodies[i].state.refPos = O.bodies[i].state.pos
O.engines[1].doSort = True  # the collider must see the bed at its new place

# 4. Couple: the block's bottom face becomes facets (or hierarchy contacts); the block is pressed down by FEM.
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[block_mat], scheme=p["scheme"],
                             averageForces=p["average_forces"], contactModel=p["contact_model"],
                             restitution=p["restitution"], timeout=60.0, label="coupling",
                             **results.implicit_options(p))
O.engines = O.engines[:3] + [coupling] + O.engines[3:]
coupling.connect()
n, windows = coupling.subcycles, int(round(p["duration_s"] / coupling.femDt))
load = p["load_pressure"] * L * W
print(f"coupled: O.dt={O.dt:.2e} s, {n} DEM steps per FEM step, {windows} windows, load {load:.1f} N", flush=True)

recorder = results.DemRecorder(out)  # dem_timeseries.h5, written as the run goes
wall_start = time.monotonic()
coupling_start = O.time  # the FEM clock starts at the handshake; record on the same clock


def record():
    recorder.append(time=O.time - coupling_start, interface_force=coupling.totalForce,
                    interface_work_dem=coupling.interfaceWorkDem, interface_work_fem=coupling.interfaceWorkFem,
                    kinetic_energy=utils.kineticEnergy(), floor_force_z=O.forces.f(floor)[2])
    if len(recorder) % max(1, windows // 8) == 0:
        print(f"t={O.time - coupling_start:.4f} s  window {coupling.window}/{windows}  block force {coupling.totalForce[2]:.1f} N "
              f"(load {load:.1f} N)  kinetic energy {recorder.last['kinetic_energy']:.2e} J  "
              f"{time.monotonic() - wall_start:.1f} s", flush=True)


O.engines = O.engines + [PyRunner(command="record()", iterPeriod=n, initRun=False)]
O.run(windows * n + 1, True)
coupling.finalize()
info = {**results.coupling_info(coupling), "steps": O.iter, "dt": O.dt, "particles": len(spheres),
        "wall_time_s": time.monotonic() - wall_start, "load_n": load,
        "final_kinetic_energy_j": utils.kineticEnergy()}
results.save_dem_outputs(out, recorder, info)
