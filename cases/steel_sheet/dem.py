# DEM participant of the steel-sheet case: wheat (spheres) settles in a closed hopper, the flaps open at t = 0 and the
# stream falls onto the coupled top face of the FEM sheet. Run by `railcosim run` as:
# railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math
import sys

import numpy as np

from railcosim.dem import CoupledDem, hertz_mindlin_contacts

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
sys.path.insert(0, p["case_dir"])  # YADE runs this file without its folder on the path
from rig import GRAVITY, Z_PARK, Rig  # noqa: E402
rng = np.random.default_rng(p["seed"])

# 1. Materials (Tables 5.1, 5.2). Hertz-Mindlin takes the smaller friction angle of a pair, so the grain's own μ acts
#    between grains and the steel's or frame's against the sheet, clamp and flaps or the hopper.
grain = O.materials.append(FrictMat(young=p["grain_young"], poisson=p["grain_poisson"], density=p["grain_density"],
                                    frictionAngle=math.atan(p["friction"]), label="wheat"))
steel = O.materials.append(FrictMat(young=p["sheet_young"], poisson=p["sheet_poisson"], density=p["sheet_density"],
                                    frictionAngle=math.atan(p["steel_friction"]), label="steel"))
frame = O.materials.append(FrictMat(young=p["frame_young"], poisson=0.3, density=7800.0,
                                    frictionAngle=math.atan(p["frame_friction"]), label="frame"))
tray_mat = O.materials.append(FrictMat(young=p["frame_young"], poisson=0.3, density=7800.0, frictionAngle=0.0,
                                       label="tray"))


def quad(a, b, c, d, material):
    """Two facets of the rectangle a-b-c-d."""
    return [O.bodies.append(utils.facet((Vector3(*a), Vector3(*b), Vector3(*c)), material=material, wire=True)),
            O.bodies.append(utils.facet((Vector3(*a), Vector3(*c), Vector3(*d)), material=material, wire=True))]


# 2. The rig (rig.py, the scene description dem_driver.py shares): the grains in the bin, then the walls in rig order,
#    the flaps last. The flaps swing down about their hinges (axis y) by 90° at a constant rate over flap_opening_s.
rig = Rig(p)
diameters, centres = rig.grains(rng)
d_max = p["diameter_max"]
grains = [O.bodies.append(utils.sphere(tuple(c), 0.5 * d, material=grain)) for c, d in zip(centres, diameters)]
masses = np.array([O.bodies[i].state.mass for i in grains])
total_mass = float(masses.sum())
materials = {"steel": steel, "frame": frame, "tray": tray_mat}
wall_ids = {}
for name, material, corners in rig.walls():
    wall_ids.setdefault(name, []).extend(quad(*corners, materials[material]))
flaps = [RotationEngine(ids=wall_ids[name], rotationAxis=(0, 1, 0), angularVelocity=0.0, rotateAroundZero=True,
                        zeroPoint=hinge, label=name) for name, (hinge, _) in rig.flap_hinges().items()]

# 3. Engines: Hertz-Mindlin with the restitution's viscous damping (Thornton 2013), the flaps, the coupling engine
#    after the contact loop, the integrator without numerical damping.
coupling = dem.coupling_engine(material=O.materials[steel], restitution=p["restitution"])
contact_loop = hertz_mindlin_contacts(p["restitution"])
integrator = NewtonIntegrator(damping=0.0, gravity=(0, 0, -GRAVITY))
O.dt = dem.time_step()

# 4. Settling in the closed hopper (uncoupled; the FEM waits): the grains fill the gap on the closed flaps, the seed's
#    initial reservoir.
if p["settle_s"] > 0 and not dem.resuming:
    O.engines = contact_loop + flaps + [integrator]
    O.run(max(1, int(round(p["settle_s"] / O.dt))), True)
    print(f"settled for {O.time:.3f} s: kinetic energy {utils.kineticEnergy():.3e} J", flush=True)
O.engines = contact_loop + flaps + [coupling, integrator]
dem.connect()  # receives the sheet's top surface, inserts its facets, sets O.dt = fem_dt / subcycles
print(f"{len(grains)} grains, {total_mass:.4f} kg, diameters {min(diameters) * 1e3:.2f}-{max(diameters) * 1e3:.2f} mm, "
      f"hopper {rig.x0:.3f}-{rig.x1:.3f} m filled to {rig.z_top - rig.z_slides:.3f} m", flush=True)


# 5. The windows. The flaps turn while t < flap_opening_s. Every bulk_record_s the masses are counted and the grains
#    that fell below the sheet parked, inert, far below (kept as bodies: the scene keeps its size for restart
#    checkpoints); the records in between repeat those figures. The mean nodal forces of the final span
#    (average_s) are summed in dem.state for the static FEM reference.
def park(i, k):
    s = O.bodies[i].state
    s.blockedDOFs = "xyzXYZ"
    s.vel, s.angVel = Vector3.Zero, Vector3.Zero
    s.pos = Vector3(10.0 + 2.0 * d_max * (k % 1000), 2.0 * d_max * (k // 1000), -10.0)


dem.state.update(parked=0, force_sum=None, force_windows=0, bulk={})
bulk_every = max(1, int(round(p["bulk_record_s"] / p["fem_dt"])))  # windows between two passes over all grains


def bulk_figures():
    """rig.bulk_figures of the grains, after parking those that have fallen below the sheet's level."""
    for i in grains:
        if Z_PARK > O.bodies[i].state.pos[2] > -1.0:
            park(i, dem.state["parked"])
            dem.state["parked"] += 1
    states = [O.bodies[i].state for i in grains]
    positions, velocities = np.array([tuple(s.pos) for s in states]), np.array([tuple(s.vel) for s in states])
    nodes = np.array([tuple(v) for v in coupling.nodePositions], dtype=float)
    return rig.bulk_figures(dem.time, positions, velocities, masses, nodes)


def record():
    t = dem.time
    speed = rig.flap_rate if t < p["flap_opening_s"] - 0.5 * O.dt else 0.0
    flaps[0].angularVelocity, flaps[1].angularVelocity = speed, -speed
    window = int(round(t / p["fem_dt"]))
    if window % bulk_every == 0 or not dem.state["bulk"]:
        dem.state["bulk"] = bulk_figures()
    if t >= p["duration_s"] - p["average_s"] - 1e-12:
        forces = np.array([tuple(f) for f in coupling.nodalForces], dtype=float)
        dem.state["force_sum"] = forces if dem.state["force_sum"] is None else dem.state["force_sum"] + forces
        dem.state["force_windows"] += 1
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(), **dem.state["bulk"])


dem.run(record, progress=lambda last: f"hopper {last['hopper_mass']:.3f} kg  passed {last['passed_mass']:.3f} kg  "
                                      f"sheet {last['sheet_mass']:.3f} kg  Fz {-last['interface_force'][2]:.3f} N")
# 6. What the post-processing reads (dem_info.json): the grains, the rig's planes, the final span's mean nodal forces.
mean_forces = dem.state["force_sum"] / max(1, dem.state["force_windows"])
dem.save(particles=len(grains), total_grain_mass_kg=total_mass, diameter_min_m=min(diameters),
         diameter_max_m=max(diameters), flow_plane_z=rig.z_flow, flaps_z=rig.z_flaps,
         final_kinetic_energy_j=utils.kineticEnergy(),
         parked=dem.state["parked"], mean_force_windows=dem.state["force_windows"],
         arrays={"triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int),
                 "node_positions": np.array([tuple(v) for v in coupling.nodePositions], dtype=float), "mean_nodal_forces": mean_forces})
