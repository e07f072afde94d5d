# DEM participant of the beam case: spheres settle on the coupled top face of the FEM beam.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math
import random

import numpy as np

from railcosim.dem import CoupledDem

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
L, W, H = p["beam_length"], p["beam_width"], p["beam_height"]
R = p["sphere_radius"]

# 1. Materials: the walls are frictionless so that all the weight of the bed rests on the beam.
particle_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                           frictionAngle=math.atan(p["friction"]), label="particles"))
wall_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                       frictionAngle=0.0, label="walls"))
beam_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["beam_density"],
                                       frictionAngle=math.atan(p["friction"]), label="beam"))

# 2. Side walls around the top face (they do not touch the beam, which lies below z = H).
for axis, position, sense in ((0, 0.0, 1), (0, L, -1), (1, 0.0, 1), (1, W, -1)):
    O.bodies.append(utils.wall(position=position, axis=axis, sense=sense, material=wall_mat))

# 3. Layers of spheres above the beam, each layer shifted by half a spacing so that its spheres sit in
#    the hollows of the one below (a stacked square lattice would stand in precarious columns that keep
#    collapsing long after the bed looks settled); jittered; density fitted so the total mass is exact.
rng = random.Random(p["seed"])
sphere_volume = 4.0 / 3.0 * math.pi * R ** 3
count = max(1, round(p["particle_mass_kg"] / (p["particle_density"] * sphere_volume)))
spacing = 2.0 * R * 1.05
layer_height = spacing * math.sqrt(0.5)  # centre rise of a sphere resting in a square hollow
jitter = 0.05 * R


def lattice_line(length, shift):
    """Centres along one side, centred so that the slack is shared by both walls (a gap at one end only
    would leave that end of the beam less loaded once the bed has settled)."""
    n = int((length - 2 * R) / spacing) + 1
    first = 0.5 * (length - (n - 1) * spacing) + shift
    return [first + k * spacing for k in range(n) if first + k * spacing <= length - R]


centres = []
layer = 0
while len(centres) < count:
    shift = 0.5 * spacing * (layer % 2)
    z = H + R * 1.02 + layer * layer_height
    for x in lattice_line(L, shift):
        for y in lattice_line(W, shift):
            if len(centres) == count:
                break
            dx, dy = (rng.uniform(-jitter, jitter) for _ in range(2))
            centres.append((min(max(x + dx, R), L - R), min(max(y + dy, R), W - R), z))
    layer += 1
density = p["particle_mass_kg"] / (count * sphere_volume)
O.materials[particle_mat].density = density
sphere_ids = [O.bodies.append(utils.sphere(c, R, material=particle_mat)) for c in centres]
total_mass = sum(O.bodies[i].state.mass for i in sphere_ids)

# 4. Engines: the coupling engine sits after the contact loop and before the integrator.
coupling = dem.coupling_engine(material=O.materials[beam_mat], restitution=p["restitution"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    # Hertz-Mindlin with viscous damping from the restitution coefficient (Thornton 2013):
                    # the bed comes to rest by dissipation in its contacts, not by numerical damping.
                    [Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=p["restitution"]),
                                                       es=MatchMaker(algo="val", val=p["restitution"]))],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    coupling,
    NewtonIntegrator(damping=p["local_damping"], gravity=(0, 0, -9.81)),
]
O.dt = dem.time_step()
dem.connect()  # receives the beam's top surface, inserts its facets, sets O.dt = fem_dt / subcycles
print(f"{count} spheres, {total_mass:.3f} kg, radius {R} m", flush=True)


# 5. Run the windows, one record per window: interface force, kinetic energy, nodal forces and kinematics.
def particles_below_surface():
    """Spheres whose centre fell below the top face: they passed through the coupled surface."""
    return sum(1 for i in sphere_ids if O.bodies[i].state.pos[2] < H - R)


def record():
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(),
                nodal_forces=coupling.nodalForces, node_positions=coupling.nodePositions,
                node_velocities=coupling.nodeVelocities, particles_below_surface=particles_below_surface())


dem.run(record, progress=lambda last: f"interface Fz={last['interface_force'][2]:.2f} N (weight {total_mass * 9.81:.2f} N)  "
                                      f"kinetic energy {last['kinetic_energy']:.3e} J")
# 6. What the post-processing reads (dem_info.json): the bed, its final state, and the surface triangles.
dem.save(particles=count, total_particle_mass_kg=total_mass, final_kinetic_energy_j=utils.kineticEnergy(),
         particles_below_surface=particles_below_surface(),
         arrays={"triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int)})
