# DEM run of the angle-of-repose case: ballast (spheres with bounded rolling friction, or sphere clusters of the shape
# library), or wheat (spheres without rolling resistance, the steel_sheet case's grain), discharged from a hopper onto a
# floor, left to come to rest. Run by `railcosim run` as:
# railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (DEM-only case: the endpoint is not used)
import math
import os
import sys

import tomllib

import numpy as np

from railcosim.dem import StandaloneDem, hertz_mindlin_contacts

dem = StandaloneDem()  # the run's parameters and results folder, from `railcosim run`
p = dem.parameters
shape = p["particle_shape"]
wheat = p["material"] == "wheat"
GRAVITY = 9.81
sys.path[:0] = [os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"), p["case_dir"]]
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402
from rig import Hopper, base_lattice, sphere_diameters  # noqa: E402

rng = np.random.default_rng(p["seed"])

# 1. Materials (Irazábal 2017 Tables 6.1, 6.2, 6.5): ballast and floor share E, ν and μ = 0.6; the hopper is
#    frictionless (thesis §6.2.1). Spheres resist rolling with η_r between them; the floor's η_r is the thesis' wall
#    value (§6.4: a stone lying with a face on a rigid wall cannot roll), the pair using the larger of the two.
#    Clusters roll on their shape alone (no rolling friction); between members of different clusters the friction
#    may depend on the contact stress (friction_model = "stress_dependent", Table 6.5).
if wheat:
    # Wheat (Ullrich 2022 Tables 5.1, 5.2): the steel_sheet case's grain (its case.toml: ρ, E, ν, e), Hertz-Mindlin
    # with the restitution's viscous damping and Coulomb friction, no rolling resistance (the seed's calibration of μ
    # to the angle of repose), the same contact law as that case (railcosim.dem.hertz_mindlin_contacts).
    with open(os.path.join(os.environ["RAILCOSIM_ROOT"], "cases", "steel_sheet", "case.toml"), "rb") as f:
        grain = tomllib.load(f)["parameters"]
    density, restitution = grain["grain_density"], grain["restitution"]
    wheat_mat = dict(young=grain["grain_young"], poisson=grain["grain_poisson"], density=density)
    ballast = O.materials.append(FrictMat(frictionAngle=math.atan(p["friction"]), label="wheat", **wheat_mat))
    floor_mat = O.materials.append(FrictMat(frictionAngle=math.atan(p["floor_friction"]), label="floor", **wheat_mat))
    hopper_mat = O.materials.append(FrictMat(frictionAngle=0.0, label="hopper", **wheat_mat))
else:
    density = p["particle_density"]
    common = dict(young=p["particle_young"], poisson=p["particle_poisson"], density=p["particle_density"],
                  restitution=p["restitution"])
    sdf = shape == "cluster" and p["friction_model"] == "stress_dependent"
    ballast = O.materials.append(BallastMat(frictionAngle=math.atan(p["friction"]),
                                            rollingFriction=p["rolling_friction"] if shape == "sphere" else 0.0,
                                            frictionExponent=p["friction_exponent"] if sdf else 0.0,
                                            maxContactStress=p["max_contact_stress"] if sdf else 0.0,
                                            label="ballast", **common))
    floor_mat = O.materials.append(BallastMat(frictionAngle=math.atan(p["floor_friction"]),
                                              rollingFriction=p["floor_rolling_friction"] if shape == "sphere" else 0.0,
                                              label="floor", **common))
    hopper_mat = O.materials.append(BallastMat(frictionAngle=0.0, rollingFriction=0.0, label="hopper", **common))

# 2. Floor (z = 0) and hopper (rig.py, shared with polyhedra_dem.py): a square funnel with walls at
#    hopper_wall_angle_deg to the horizontal, narrowing to the square aperture (side hopper_aperture) at drop_height
#    above the floor, and a vertical square bin on top of it that holds the initial lattice. The hopper's axis is the
#    z axis. With base_radius > 0 the pile forms on a base of that radius (the fixed-base test, e.g. ISO 4324; step 3).
floor = O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=floor_mat))
hopper = Hopper(p)  # rig.py: the scene's geometry, shared with polyhedra_dem.py
z0 = hopper.z0


# 3. Ballast: sizes drawn from the middle of the EN 13450 band (thesis Table 2.1) until the mass reaches ballast_mass_kg,
#    sphere diameter = sieve size; clusters of the shape library ("coarse" 7-16, "fine" 29-45 spheres, §5.3.4; or
#    "angular") at their sieve size, randomly turned. They start at rest on a jittered lattice filling the hopper from
#    the aperture up, and flow out as soon as the run starts (no gate: the thesis' hopper holds no stored material
#    either).
#    Wheat: diameters uniform in [grain_diameter_min, grain_diameter_max] (Ullrich 2022 Table 5.1: 3-5 mm).
if shape == "sphere":
    reaches = 0.5 * sphere_diameters(p, rng, density, wheat)
else:
    library = ballast_clusters.loadShapeLibrary()
    stones = ballast_clusters.sampleBallastStones(library, rng, p["ballast_mass_kg"] / p["particle_density"],
                                                  level=p["cluster_level"], density=p["particle_density"])
    reaches = np.array([s["enclosingRadius"] for s in stones])
count = len(reaches)
centres, bin_top, lattice_order = hopper.lattice(reaches, rng)
# The fixed base (base_radius > 0): a disc of fixed spheres of the particles' mean diameter (of their enclosing spheres
# for clusters), touching on a hexagonal lattice, lying on the floor, as a base with glued grains; spheres without
# rolling resistance roll off a flat base for ever, its first layer included. What passes the base's edge falls to the
# floor and leaves the scene (step 5).
base_ids, base_top = [], 0.0
if p["base_radius"] > 0.0:
    d_base = base_top = 2.0 * float(reaches.mean())
    for x, y in base_lattice(p["base_radius"], d_base):
        base_ids.append(O.bodies.append(utils.sphere((x, y, 0.5 * d_base), 0.5 * d_base, fixed=True,
                                                     material=floor_mat)))
particle_ids = []
for k in lattice_order:  # bodies in the lattice's order, bottom row first
    if shape == "sphere":
        particle_ids.append(O.bodies.append(utils.sphere(tuple(centres[k]), float(reaches[k]), material=ballast)))
    else:
        particle_ids.append(pack_ballast.addClusterStone(stones[k], tuple(centres[k]), O.materials[ballast]))
for quad in hopper.walls(bin_top):
    quad = [Vector3(*c) for c in quad]
    O.bodies.append(utils.facet((quad[0], quad[1], quad[2]), material=hopper_mat, wire=True))
    O.bodies.append(utils.facet((quad[0], quad[2], quad[3]), material=hopper_mat, wire=True))
# The sliding gate (hopper_gate_s > 0, rig.py): a frictionless plate at the aperture that holds the ballast until
# hopper_gate_s, then slides out along +x at hopper_gate_speed (a fixed body with a velocity: the integrators move it).
gate_ids, gate_travel, gate_stop = [], 0.0, [math.inf]
if p["hopper_gate_s"] > 0.0:
    plate, gate_travel = hopper.gate()
    gate_ids = [O.bodies.append(utils.facet([Vector3(*c) for c in t], material=hopper_mat, wire=True)) for t in plate]

total_mass = sum(O.bodies[i].state.mass for i in particle_ids)
spheres_per_particle = sum(1 for b in O.bodies if b.isClumpMember) / count if shape == "cluster" else 1
print(f"{count} {shape}s ({spheres_per_particle:.1f} spheres each), {total_mass:.2f} kg, lattice up to {bin_top:.3f} m",
      flush=True)

# 4. Engines: the ballast contact law (Hertz-Mindlin with the restitution's viscous damping, Coulomb or stress-dependent
#    friction, docs/contact-models.md); bounded rolling friction on spheres (after the contact loop, before an
#    integrator without numerical damping); clusters rotate by the Zhao-van Wachem quaternion scheme (thesis §5.3).
#    Wheat: Hertz-Mindlin without rolling resistance (the steel_sheet case's contacts).
O.engines = (hertz_mindlin_contacts(restitution, walls=True) if wheat else [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
]) + ([BoundedRollingFrictionEngine()] if shape == "sphere" and not wheat else []) + [
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -GRAVITY)) if shape == "sphere" else
    QuaternionIntegrator(scheme="zhaoVanWachem", damping=0.0, gravity=(0, 0, -GRAVITY)),
]
O.dt = p["dem_dt"] if shape == "sphere" else p["cluster_dt"]


# 5. Discharge and rest: the run goes on in spans of rest_check_s until the hopper is empty and every particle moves
#    slower than rest_speed, or for duration_s at most. Recorded every record_every_s. With a fixed base (base_radius
#    > 0) the particles that fell over its edge are removed at each record: a centre (a cluster's centre of
#    mass) below the base's top (z < d_base), within d_base of the base's edge or beyond it, is on the floor or
#    caught between the outermost base spheres (on the base a sphere of 3/4 of the base spheres'
#    diameter in a hole of three of them rests with its centre 1.16 d_base high); their energy then (potential +
#    kinetic) is kept in left_energy for the energy balance.
def in_hopper_mass():
    return sum(O.bodies[i].state.mass for i in particle_ids if O.bodies[i].state.pos[2] > z0)


def potential_energy():
    return GRAVITY * sum(O.bodies[i].state.mass * O.bodies[i].state.pos[2] for i in particle_ids)


left_energy, left_mass = [0.0], [0.0]


def remove_fallen():
    """Removes the particles (spheres, or clusters with their members) that fell over the fixed base's edge (a no-op
    without a base)."""
    if p["base_radius"] <= 0.0:
        return
    for i in list(particle_ids):
        b = O.bodies[i]
        s = b.state
        # on the floor or caught in the base's rim; not a small stone wedged between the base's spheres inside it
        if s.pos[2] < base_top and math.hypot(s.pos[0], s.pos[1]) > p["base_radius"] - base_top:
            spin = s.ori.conjugate() * s.angVel  # in the principal axes, where the inertia is diagonal
            rotation = sum(s.inertia[k] * spin[k] ** 2 for k in range(3))
            left_energy[0] += s.mass * (GRAVITY * s.pos[2] + 0.5 * s.vel.squaredNorm()) + 0.5 * rotation
            left_mass[0] += s.mass
            particle_ids.remove(i)
            O.bodies.erase(i, True)  # a cluster's members with it


def floor_force():
    """Vertical force of the particles on the floor and the fixed base."""
    return -sum(O.forces.f(i)[2] for i in [floor] + base_ids)


def record():
    remove_fallen()
    if O.time >= gate_stop[0]:  # the gate has cleared the aperture: it stays there
        for i in gate_ids:
            O.bodies[i].state.vel = Vector3.Zero
        gate_stop[0] = math.inf
    speeds = [O.bodies[i].state.vel.norm() for i in particle_ids]
    return {"kinetic_energy": utils.kineticEnergy(), "potential_energy": potential_energy(),
            "left_energy": left_energy[0], "left_mass": left_mass[0],
            "hopper_mass": in_hopper_mass(), "max_speed": max(speeds), "floor_force": floor_force(),
            "floor_impulse": floor_impulse[0]}


def progress(last):
    fastest = max((O.bodies[i].state for i in particle_ids), key=lambda s: s.vel.norm())
    return (f"hopper {last['hopper_mass']:.1f} kg  max speed {last['max_speed']:.3f} m/s "
            f"(at {', '.join(f'{x:.3f}' for x in fastest.pos)} m, spin {fastest.angVel.norm():.1f} rad/s)  "
            f"floor {last['floor_force'] / (total_mass * GRAVITY):.3f} W")


initial_energy = potential_energy()  # at rest on the lattice, no contact: kinetic and elastic energy are 0
floor_impulse = [0.0]
if gate_ids:
    dem.run(p["hopper_gate_s"], record, p["record_every_s"], progress)  # the ballast settles on the closed gate
    for i in gate_ids:
        O.bodies[i].state.vel = Vector3(p["hopper_gate_speed"], 0.0, 0.0)
    gate_stop[0] = O.time + gate_travel / p["hopper_gate_speed"]
    print(f"gate opens at t = {O.time:.3f} s", flush=True)
while O.time < p["duration_s"] - 0.5 * O.dt:
    dem.run(min(p["rest_check_s"], p["duration_s"] - O.time), record, p["record_every_s"], progress)
    if dem.last["hopper_mass"] == 0.0 and dem.last["max_speed"] < p["rest_speed"]:
        print(f"at rest at t = {O.time:.3f} s", flush=True)
        break
# One more rest_check_s with the floor's impulse summed every step, for its mean reaction over that window (samples of
# a contact force rattle). Only then: a Python call per step costs several times a small scene's step.
O.engines = O.engines + [PyRunner(iterPeriod=1, command="floor_impulse[0] += floor_force() * O.dt")]
dem.run(p["rest_check_s"], record, p["record_every_s"], progress)

# 6. The pile: every sphere (cluster members for clusters) with its radius, for the profile fit of the post-processing.
base_set = set(base_ids)
members = [b for b in O.bodies if isinstance(b.shape, Sphere) and b.id not in base_set]
spheres = np.array([(b.state.pos[0], b.state.pos[1], b.state.pos[2], b.shape.radius) for b in members])
centres_now = np.array([tuple(O.bodies[i].state.pos) for i in particle_ids])
masses = np.array([O.bodies[i].state.mass for i in particle_ids])
dem.save(arrays={"spheres": spheres, "particle_centres": centres_now, "particle_masses": masses},
         particles=count, spheres=len(members), ballast_mass_kg=total_mass, simulated_s=O.time, material=p["material"],
         left_particles=count - len(particle_ids), left_mass_kg=left_mass[0], base_spheres=len(base_ids),
         base_top_m=base_top,
         initial_energy_j=initial_energy,
         at_rest=bool(dem.last["hopper_mass"] == 0.0 and dem.last["max_speed"] < p["rest_speed"]),
         mean_diameter_m=float(2.0 * reaches.mean()) if shape == "sphere" else float(
             np.mean([s["sieveSize"] for s in stones])))
