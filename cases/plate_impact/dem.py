# DEM participant of the plate impact: one elastic sphere strikes the coupled top face of the FEM plate.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import json
import math
import os
import sys
import time

import numpy as np

import railcosim_results as results

params_path, endpoint, out = sys.argv[1], sys.argv[2], sys.argv[3]
with open(params_path) as f:
    p = json.load(f)
L, T, R = p["plate_length"], p["plate_thickness"], p["sphere_radius"]

# 1. Frictionless steel: the sphere exchanges only normal impulse, so its spin stays zero.
sphere_mat = O.materials.append(FrictMat(young=p["plate_young"], poisson=p["plate_poisson"],
                                         density=p["sphere_density"], frictionAngle=0.0))
plate_mat = O.materials.append(FrictMat(young=p["plate_young"], poisson=p["plate_poisson"],
                                        density=p["plate_density"], frictionAngle=0.0))
sphere = O.bodies.append(utils.sphere((L / 2, L / 2, T + R + 2e-5), R, material=sphere_mat))
O.bodies[sphere].state.vel = (0, 0, -p["impact_velocity"])

# 2. The engine finds the contact with the facet/edge/vertex hierarchy; restitution 1 = no contact damping.
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[plate_mat], scheme=p["scheme"],
                             averageForces=p["average_forces"], contactModel="hierarchy", restitution=1.0,
                             subcycles=int(round(p["fem_dt"] / p["dem_dt"])), timeout=60.0, label="coupling",
                             **results.implicit_options(p))
O.engines = [ForceResetter(), coupling, NewtonIntegrator(damping=0.0, gravity=(0, 0, 0))]
O.dt = p["dem_dt"]
coupling.connect()
n, windows = coupling.subcycles, int(round(p["duration_s"] / coupling.femDt))
mass = O.bodies[sphere].state.mass
initial_energy = 0.5 * mass * p["impact_velocity"] ** 2
print(f"sphere {mass:.4f} kg at {p['impact_velocity']} m/s ({initial_energy:.4e} J); O.dt={O.dt:.2e} s, "
      f"{n} DEM steps per FEM step, {windows} windows", flush=True)

# 3. One record per window: sphere velocity and energy, contact force, interface work seen by each side
#    (dem_timeseries.h5, written as the run goes).
recorder = results.DemRecorder(out)
contact_windows = 0


def record():
    global contact_windows
    s = O.bodies[sphere].state
    recorder.append(time=O.time, sphere_velocity_z=s.vel[2],
                    sphere_kinetic_energy=0.5 * mass * s.vel.squaredNorm() + 0.5 * s.inertia.dot(
                        Vector3(s.angVel[0] ** 2, s.angVel[1] ** 2, s.angVel[2] ** 2)),
                    interface_force_z=coupling.totalForce[2], interface_work_dem=coupling.interfaceWorkDem,
                    interface_work_fem=coupling.interfaceWorkFem, surface_contacts=coupling.surfaceContacts)
    contact_windows += coupling.surfaceContacts > 0


O.engines = O.engines + [PyRunner(command="record()", iterPeriod=n, initRun=False)]
wall_start = time.monotonic()
O.run(windows * n + 1, True)
coupling.finalize()
wall = time.monotonic() - wall_start
info = {**results.coupling_info(coupling), "steps": O.iter, "dt": O.dt, "particles": 1, "wall_time_s": wall,
        "initial_energy_j": initial_energy,
        "final_sphere_energy_j": recorder.last["sphere_kinetic_energy"], "contact_windows": int(contact_windows)}
results.save_dem_outputs(out, recorder, info)
print(f"done: rebound {recorder.last['sphere_velocity_z']:.4f} m/s, sphere keeps "
      f"{info['final_sphere_energy_j'] / initial_energy:.2%} of its energy; {wall:.1f} s", flush=True)
