# DEM participant of the clump restart test: two-sphere clumps (aspherical: QuaternionIntegrator's Zhao-van Wachem
# rotation with its half-step state) fall onto the stand-in FEM's surface (mesh contacts, implicit scheme).
import math
import random

from railcosim.dem import CoupledDem

dem = CoupledDem()
p = dem.parameters
R = p["sphere_radius"]
rng = random.Random(p["seed"])

# 1. One material for the particles and the surface.
mat = O.materials.append(FrictMat(young=5e7, poisson=0.3, density=2600, frictionAngle=math.atan(0.5)))

# 2. Clumps on a grid over the 0.18 m square surface, each turned by a random angle (so that they tumble).
clumps = []
for i in range(p["clumps_x"]):
    for j in range(p["clumps_y"]):
        x, y = 0.02 + (i + 0.5) * 0.14 / p["clumps_x"], 0.02 + (j + 0.5) * 0.14 / p["clumps_y"]
        angle = rng.uniform(0, math.pi)
        dx, dy = 0.7 * R * math.cos(angle), 0.7 * R * math.sin(angle)
        z = R + p["drop_height"] + 0.3 * R * j
        members = [utils.sphere((x + s * dx, y + s * dy, z + 0.2 * s * R), R, material=mat) for s in (-1, 1)]
        clumps.append(O.bodies.appendClumped(members)[0])

# 3. Engines: Hertz-Mindlin between the particles, the coupling engine's mesh contacts with the surface.
coupling = dem.coupling_engine(material=O.materials[mat], restitution=p["restitution"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=p["restitution"]),
                                                       es=MatchMaker(algo="val", val=p["restitution"]))],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    coupling,
    QuaternionIntegrator(gravity=(0, 0, -9.81)),
]
O.dt = dem.time_step()
dem.connect()


# 4. One record per window: the force on the surface, the clumps' energy and mean height, a count kept in dem.state.
dem.state["windows_in_contact"] = 0


def record():
    dem.state["windows_in_contact"] += int(coupling.surfaceContacts > 0)
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(),
                mean_height=sum(O.bodies[c].state.pos[2] for c in clumps) / len(clumps),
                orientations=[tuple(O.bodies[c].state.ori) for c in clumps])


dem.run(record)
dem.save(particles=len(clumps), final_kinetic_energy_j=utils.kineticEnergy(),
         windows_in_contact=dem.state["windows_in_contact"])
