# DEM participant of the block case: a bed of spheres settles in a box, then carries the coupled block.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math
import random
import time

from railcosim.dem import CoupledDem

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
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
O.dt = dem.time_step()
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

# 4. Couple: the block's bottom face becomes facets (or mesh contacts); the block is pressed down by FEM.
coupling = dem.coupling_engine(material=O.materials[block_mat], restitution=p["restitution"])
O.engines = O.engines[:3] + [coupling] + O.engines[3:]
dem.connect()  # records from here on the FEM clock, which starts at the handshake
load = p["load_pressure"] * L * W
print(f"{len(spheres)} spheres under a load of {load:.1f} N", flush=True)


# 5. Run the windows, one record per window: the force on the block, kinetic energy, the floor's reaction.
def record():
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(),
                floor_force_z=O.forces.f(floor)[2])


dem.run(record, progress=lambda last: f"block force {last['interface_force'][2]:.1f} N (load {load:.1f} N)  "
                                      f"kinetic energy {last['kinetic_energy']:.2e} J")
# 6. What the post-processing reads (dem_info.json): the bed, the load and the final state.
dem.save(particles=len(spheres), load_n=load, final_kinetic_energy_j=utils.kineticEnergy())
