# DEM participant of the sleeper-on-ballast case on YADE: the prepared bed (bed.py) under the FEM sleeper, through the
# load pattern; records the interface force, the sensors' top-face forces and the energy audit (loadrun.py, shared with
# the standalone driver dem_driver.py).
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (after bed.py, which leaves bed.json)
import math
import os
import sys

import numpy as np

from railcosim.dem import CoupledDem

CASE_DIR = os.path.join(os.environ["RAILCOSIM_ROOT"], "cases", "sleeper_on_ballast")
sys.path.insert(0, CASE_DIR)
import loadrun  # noqa: E402
import preparation as prep  # noqa: E402
import yade_engine as ye  # noqa: E402  (also O, FrictMat, Vector3 ...)
from yade import O  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402
from yade.wrapper import FrictMat  # noqa: E402

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
scene, bed_record, bed, attrs = loadrun.prepared_bed(p, dem.out)  # sets p["duration_s"]

# 1. Materials: ballast, smooth box walls, and the sleeper's surface (loadrun.sleeper_material).
stone_mat, wall_mat = ye.materials(scene)
sleeper_mat = O.materials.append(FrictMat(young=p["sleeper_young"], poisson=p["sleeper_poisson"],
                                          density=p["sleeper_density"], frictionAngle=math.atan(p["friction"]),
                                          label="sleeper"))

# 2. The box (walls up to the sleeper's top and beyond) and the prepared bed: stones and the five sensor blocks.
seat = float(attrs["seat_height_m"])
ye.facets(loadrun.wall_corners(scene, seat), wall_mat)
poly = ye.polyhedra_engine(scene, bed, p)
ids = ye.add_bodies(scene, bed, stone_mat, poly)
index_of_body = {b: i for i, b in enumerate(ids)}
stones = [ids[i] for i in np.flatnonzero(bed.kind == prep.STONE)]

# 3. Time step (loadrun.time_step); a separate engine, so that the coupled one is initialized only once its surface is
#    there.
probe = ye.polyhedra_engine(scene, bed, p)
for i, b in enumerate(ids):
    probe.addStone(b, [Vector3(*v) for v in bed.core(scene, i)], float(bed.dilation[i]))
O.engines = [probe]
O.dt = 1e-6
O.dt, critical, design = loadrun.time_step(p, scene, probe.criticalTimeStep)

# 4. Couple: the sleeper's bottom face joins the polyhedra engine's walls; the coupling engine advances the stones one
#    window at a time.
coupling = dem.coupling_engine(material=O.materials[sleeper_mat], restitution=p["restitution"])
O.engines = [coupling, poly]
dem.connect()  # receives the sleeper's bottom face, sets O.dt = fem_dt / subcycles
poly.initialize()
mass = sum(O.bodies[b].state.mass for b in stones)
sensors = loadrun.Sensors(p, scene, bed)
print(f"{len(stones)} stones ({mass:.1f} kg) and {len(sensors.indices)} sensors from {bed_record['path']}; sleeper "
      f"bottom at z = {seat:.4f} m; O.dt {O.dt:.3e} s = {O.dt / critical:.3f} x the critical step {critical:.3e} s "
      f"(contacts of {design['contact_force_n']:.0f} N, impacts at {design['impact_speed_m_s']:g} m/s); "
      f"{poly.activeBackend}", flush=True)


class Window:
    """What loadrun.Sensors reads of a window, from YADE."""

    def frames(self, indices):
        return ye.states([ids[i] for i in indices])[:2]

    def contacts(self):
        return ye.contacts(poly, index_of_body)

    @property
    def interface_force(self):
        return tuple(coupling.totalForce)

    @property
    def surface_force(self):
        return tuple(poly.surfaceForce)


window = Window()
# Windows counted by the coupling engine (restored with a restart checkpoint), not by this script.
dem.run(lambda: sensors.record(window, coupling.window),
        progress=lambda last: f"sleeper carried {last['interface_force'][2] / 1e3:.2f} kN")
# 5. What the post-processing reads (dem_info.json): the bed, the time step, the sensors.
dem.save(particles=len(stones), stones=len(stones), sensors=len(sensors.indices), particle_mass_kg=mass,
         critical_time_step_s=critical, design_contact_force_n=design["contact_force_n"], seat_height_m=seat,
         sensor_period_windows=sensors.every, polyhedra_backend=poly.activeBackend, dem_driver=ye.DRIVER,
         polyhedra_time_s=coupling.polyhedraTime, bed=bed_record)
