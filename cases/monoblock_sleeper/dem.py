# DEM participant of the monoblock sleeper case: spheres settle on the base of the turned-over sleeper (the base at z = 0,
# x in [0, 2.6], y in [-0.15, 0.15] m). Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math
import random

import numpy as np

from railcosim.dem import CoupledDem, hertz_mindlin_contacts

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
L, HALF_W, R = 2.6, 0.15, p["sphere_radius"]

# 1. Materials: the walls are frictionless so that all the weight of the bed rests on the sleeper.
particle_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                           frictionAngle=math.atan(p["friction"])))
wall_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                       frictionAngle=0.0))
sleeper_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["sleeper_density"],
                                          frictionAngle=math.atan(p["friction"])))

# 2. Side walls on the edges of the base (the sleeper lies below z = 0, inside them).
for axis, position, sense in ((0, 0.0, 1), (0, L, -1), (1, -HALF_W, 1), (1, HALF_W, -1)):
    O.bodies.append(utils.wall(position=position, axis=axis, sense=sense, material=wall_mat))

# 3. Layers of spheres above the base, each shifted by half a spacing into the hollows of the one below, the slack
#    shared by both walls (a gap at one end only would leave that end less loaded); the last layer, when only part of
#    it is needed, takes evenly spread sites (filled from one end it would load that end of the sleeper more: 11 %
#    more on one half, 1.2 % on the deflection); jittered; the density fitted so that the total mass is exact.
rng = random.Random(p["seed"])
spacing = 2.0 * R * 1.05
volume = 4.0 / 3.0 * math.pi * R ** 3
count = max(1, round(p["particle_mass_kg"] / (p["particle_density"] * volume)))


def line(low, high, shift):
    n = int((high - low - 2 * R) / spacing) + 1
    first = low + 0.5 * (high - low - (n - 1) * spacing) + shift
    return [first + k * spacing for k in range(n) if first + k * spacing <= high - R]


centres, layer = [], 0
while len(centres) < count:
    shift = 0.5 * spacing * (layer % 2)
    sites = [(x, y) for x in line(0.0, L, shift) for y in line(-HALF_W, HALF_W, shift)]
    needed = min(len(sites), count - len(centres))
    for k in range(needed):
        x, y = sites[k * len(sites) // needed]
        jitter = [rng.uniform(-0.05 * R, 0.05 * R) for _ in range(2)]
        centres.append((min(max(x + jitter[0], R), L - R), min(max(y + jitter[1], -HALF_W + R), HALF_W - R),
                        R * 1.02 + layer * spacing * math.sqrt(0.5)))
    layer += 1
O.materials[particle_mat].density = p["particle_mass_kg"] / (count * volume)
spheres = [O.bodies.append(utils.sphere(c, R, material=particle_mat)) for c in centres]

# 4. Engines: Hertz-Mindlin with viscous damping from the restitution coefficient, so that the bed comes to rest by
#    dissipation in its contacts; the coupling engine between the contact loop and the integrator.
coupling = dem.coupling_engine(material=O.materials[sleeper_mat], restitution=p["restitution"])
O.engines = [
    *hertz_mindlin_contacts(p["restitution"], walls=True),
    coupling,
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
]
O.dt = dem.time_step()
dem.connect()  # receives the sleeper's base, inserts its facets, sets O.dt = fem_dt / subcycles
total_mass = sum(O.bodies[i].state.mass for i in spheres)
print(f"{count} spheres in {layer} layers, {total_mass:.2f} kg, radius {R} m", flush=True)


# 5. Run the windows, one record per window: interface force, kinetic energy, nodal forces and kinematics.
def record():
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(),
                nodal_forces=coupling.nodalForces, node_positions=coupling.nodePositions,
                node_velocities=coupling.nodeVelocities)


dem.run(record, progress=lambda last: f"interface Fz={last['interface_force'][2]:.1f} N (weight {total_mass * 9.81:.1f} N)"
                                      f"  kinetic energy {last['kinetic_energy']:.3e} J")
# 6. What the post-processing reads (dem_info.json): the bed, its final state, and the surface triangles.
dem.save(particles=count, total_particle_mass_kg=total_mass, final_kinetic_energy_j=utils.kineticEnergy(),
         arrays={"triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int)})
