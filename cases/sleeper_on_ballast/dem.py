# DEM participant of the sleeper-on-ballast case: the prepared bed (bed.py) under the FEM sleeper, through the load
# pattern; records the interface force, the sensors' top-face forces and the energy audit.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (after bed.py, which leaves bed.json)
import json
import math
import os
import sys
import time

import numpy as np

from railcosim.dem import CoupledDem

CASE_DIR = os.path.join(os.environ["RAILCOSIM_ROOT"], "cases", "sleeper_on_ballast")
sys.path.insert(0, CASE_DIR)
import bed as bedfile  # noqa: E402  (the bed's bodies, materials, walls)
import scene as sc  # noqa: E402

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
scene = sc.build(p)
with open(os.path.join(dem.out, "bed.json")) as f:
    bed_record = json.load(f)
bed, attrs = bedfile.load(bed_record["path"])
dem.parameters["duration_s"] = sc.load_run_duration(p)  # the windows of the pattern (and any rest after it)

# 1. Materials: ballast, smooth box walls, and the sleeper's surface (timber; its elasticity is FreeFEM's, this sets
#    the contact: timber's E and nu, the ballast's friction and restitution).
stone_mat, wall_mat = bedfile.materials(scene)
sleeper_mat = O.materials.append(FrictMat(young=p["sleeper_young"], poisson=p["sleeper_poisson"],
                                          density=p["sleeper_density"], frictionAngle=math.atan(p["friction"]),
                                          label="sleeper"))

# 2. The box (walls up to the sleeper's top and beyond) and the prepared bed: stones and the five sensor blocks.
length, width, _ = scene["bed"]
seat = float(attrs["seat_height_m"])
bedfile.box_walls(length, width, seat + sc.SLEEPER_SIZE[2] + 0.1, wall_mat)
poly = bedfile.polyhedra_engine(scene, bed, backend=p["polyhedra_backend"])
ids = bedfile.add_bodies(scene, bed, stone_mat, poly)
sensors = [ids[i] for i in np.flatnonzero(bed.kind == bedfile.SENSOR)]
sensors.sort(key=lambda b: O.bodies[b].state.pos[0])  # x order
stones = [ids[i] for i in np.flatnonzero(bed.kind == bedfile.STONE)]

# 3. Time step: the contact law's critical step for the load run's design loads (scene.design_contact_loads), over the
#    bed's stone templates, times critical_step_fraction; a separate engine, so that the coupled one is initialized
#    only once its surface is there.
design = sc.design_contact_loads(p, scene, "load")
probe = bedfile.polyhedra_engine(scene, bed)
for i, b in enumerate(ids):
    probe.addStone(b, [Vector3(*v) for v in bed.core(scene, i)], float(bed.dilation[i]))
O.engines = [probe]
O.dt = 1e-6
critical = probe.criticalTimeStep(design["contact_force_n"], design["impact_speed_m_s"])
O.dt = p["critical_step_fraction"] * critical

# 4. Couple: the sleeper's bottom face joins the polyhedra engine's walls; the coupling engine advances the stones one
#    window at a time.
coupling = dem.coupling_engine(material=O.materials[sleeper_mat], restitution=p["restitution"])
O.engines = [coupling, poly]
dem.connect()  # receives the sleeper's bottom face, sets O.dt = fem_dt / subcycles
poly.initialize()
mass = sum(O.bodies[b].state.mass for b in stones)
print(f"{len(stones)} stones ({mass:.1f} kg) and {len(sensors)} sensors from {bed_record['path']}; sleeper bottom at "
      f"z = {seat:.4f} m; O.dt {O.dt:.3e} s = {O.dt / critical:.3f} x the critical step {critical:.3e} s (contacts of "
      f"{design['contact_force_n']:.0f} N, impacts at {design['impact_speed_m_s']:g} m/s); {poly.activeBackend}",
      flush=True)

# 5. Sensors: pressure = vertical force on the top face / its area (Ullrich 2022: the load on the sensor's top face). A
#    contact is on the top face when its point, in the sensor's frame, lies within the top face's dilation layer.
half_height = 0.5 * sc.SENSOR_SIZE[2]
r_s = scene["sensors"]["dilation"]
sensor_index = {b: k for k, b in enumerate(sensors)}
SENSOR_EVERY = max(1, int(round(p["sensor_period_s"] / p["fem_dt"])))  # windows between sensor readings


def sensor_top_forces():
    """Downward force [N] on each sensor's top face, from the contacts of the last step (x order)."""
    forces = np.zeros(len(sensors))
    frames = [(O.bodies[b].state.pos, O.bodies[b].state.ori.conjugate()) for b in sensors]
    for c in poly.contacts():
        for key, sign in (("id2", 1.0), ("id1", -1.0)):  # `force` acts on id2; id1 receives the opposite
            k = sensor_index.get(c[key])
            if k is None:
                continue
            position, inverse = frames[k]
            local = inverse * (c["point"] - position)
            if local[2] >= half_height - 2.0 * r_s:
                forces[k] -= sign * c["force"][2]
    return forces


def record():
    # Counted by the coupling engine's window (restored with a restart checkpoint), not by this script.
    readings = sensor_top_forces() if coupling.window % SENSOR_EVERY == 0 else np.full(len(sensors), np.nan)
    return dict(interface_force=coupling.totalForce, surface_force=poly.surfaceForce, sensor_top_force=readings,
                sensor_height=[O.bodies[b].state.pos[2] for b in sensors])


dem.run(record, progress=lambda last: f"sleeper carried {last['interface_force'][2] / 1e3:.2f} kN")
# 6. What the post-processing reads (dem_info.json): the bed, the time step, the sensors.
dem.save(particles=len(stones), stones=len(stones), sensors=len(sensors), particle_mass_kg=mass,
         critical_time_step_s=critical, design_contact_force_n=design["contact_force_n"], seat_height_m=seat,
         sensor_period_windows=SENSOR_EVERY, polyhedra_backend=poly.activeBackend,
         polyhedra_time_s=coupling.polyhedraTime, bed=bed_record)
