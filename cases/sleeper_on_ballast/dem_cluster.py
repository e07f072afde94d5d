# DEM participant of the sleeper-on-ballast case with sphere clusters (particle_shape = "cluster") on YADE: the cluster
# bed (bed.py) under the FEM sleeper, through the load pattern; the sleeper's bottom face touches the clusters' members
# through FemCouplingEngine's mesh contacts (contactModel 'meshContacts', the BallastMat law). Records what dem.py
# records (loadrun.Sensors) and the ballast's mechanical energy for the energy bound.
# Run by `railcosim run` as: railcosim yade dem_cluster.py PARAMETERS.json ENDPOINT OUTDIR (after bed.py)
import math
import os
import sys

import numpy as np

from railcosim.dem import CoupledDem

CASE_DIR = os.path.join(os.environ["RAILCOSIM_ROOT"], "cases", "sleeper_on_ballast")
sys.path.insert(0, CASE_DIR)
import cluster_engine as ce  # noqa: E402  (also O, BallastMat ...)
import loadrun  # noqa: E402
import preparation as prep  # noqa: E402
from yade import O  # noqa: E402
from yade.wrapper import BallastMat  # noqa: E402

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
scene, bed_record, bed, attrs = loadrun.prepared_bed(p, dem.out)  # sets p["duration_s"]

# 1. Time step (loadrun.time_step): the clusters' contact law for the load run's design loads; the damping ratio from
#    a probe contact (an empty scene, before the bed is built).
gamma = ce.damping_ratio(scene)
O.dt, critical, design = loadrun.time_step(
    p, scene, lambda force, speed: ce.critical_time_step(scene, bed, p["cluster_level"], gamma, force, speed))
step = O.dt

# 2. Materials: ballast, smooth box walls, and the sleeper's surface (timber's E and nu, the ballast's friction and
#    restitution, as loadrun.sleeper_material).
stone_mat, wall_mat = ce.materials(scene)
sleeper_mat = O.materials.append(BallastMat(young=p["sleeper_young"], poisson=p["sleeper_poisson"],
                                            density=p["sleeper_density"], restitution=p["restitution"],
                                            frictionAngle=math.atan(p["friction"]), label="sleeper"))

# 3. The box (walls up to the sleeper's top and beyond) and the prepared bed: clusters and the five sensor boxes.
seat = float(attrs["seat_height_m"])
ce.facets(loadrun.wall_corners(scene, seat), wall_mat)
ids, offsets = ce.add_bodies(scene, bed, stone_mat, p["cluster_level"])
index_of_body = {b: i for i, b in enumerate(ids)}
stones = [ids[i] for i in np.flatnonzero(bed.kind == prep.STONE)]
sensors = loadrun.Sensors(p, scene, bed)
sensor_ids = [ids[i] for i in sensors.indices]

# 4. Couple: the sleeper's bottom face as mesh contacts of the members (contact_model names the polyhedra path's
#    surface; a cluster bed has no polyhedra engine).
coupling = dem.coupling_engine(material=O.materials[sleeper_mat], restitution=p["restitution"],
                               contactModel="meshContacts")
O.engines = ce.engines(coupling=coupling)
O.dt = step
dem.connect()  # receives the sleeper's bottom face, sets O.dt = fem_dt / subcycles
mass = sum(O.bodies[b].state.mass for b in stones)
members = sum(1 for b in O.bodies if b.isClumpMember)
energy_start = ce.mechanical_energy(ids)
print(f"{len(stones)} {p['cluster_level']} clusters ({members} spheres, {mass:.1f} kg) and {len(sensor_ids)} sensor boxes "
      f"from {bed_record['path']}; sleeper bottom at z = {seat:.4f} m; O.dt {O.dt:.3e} s = {O.dt / critical:.3f} x the "
      f"critical step {critical:.3e} s (contacts of {design['contact_force_n']:.0f} N, impacts at "
      f"{design['impact_speed_m_s']:g} m/s; damping ratio {gamma:.3f})", flush=True)


class Window:
    """What loadrun.Sensors reads of a window, from YADE's clumps and boxes."""

    def frames(self, indices):
        return ce.states([ids[i] for i in indices], [offsets[i] for i in indices])[:2]

    def contacts(self):
        return ce.sensor_contacts(sensor_ids, index_of_body)

    @property
    def interface_force(self):
        return tuple(coupling.totalForce)

    @property
    def surface_force(self):
        return tuple(coupling.totalForce)  # mesh contacts: the window's mean force of the members on the face


window = Window()
elastic_start = None


def record():
    """loadrun.Sensors' record and the ballast's mechanical energy gain since the start (kinetic + gravitational, J)."""
    global elastic_start
    if elastic_start is None:  # the contacts' elastic energy when the load run starts (after its first window)
        elastic_start = ce.contact_elastic_energy()
    return {**sensors.record(window, coupling.window), "mechanical_energy_gain": ce.mechanical_energy(ids) - energy_start}


dem.run(record, progress=lambda last: f"sleeper carried {last['interface_force'][2] / 1e3:.2f} kN; "
                                        f"{coupling.implicitPasses} passes, scene checkpoints {coupling.checkpointTime:.1f} s")
# 5. What the post-processing reads (dem_info.json): the bed, the time step, the sensors, the energy bound's terms.
dem.save(particles=len(stones), stones=len(stones), sensors=len(sensor_ids), particle_mass_kg=mass,
         cluster_spheres=members, cluster_level=p["cluster_level"], particle_shape="cluster",
         contact_model="meshContacts", critical_time_step_s=critical, damping_ratio=gamma,
         design_contact_force_n=design["contact_force_n"], seat_height_m=seat, sensor_period_windows=sensors.every,
         contact_elastic_energy_start_j=elastic_start, dem_driver="yade", bed=bed_record)
