# YADE participant of the lateral resistance case (DEM only): a rigid NS90 sleeper in a bed of spheres between two
# mirror walls is pushed along its axis at a set speed, vertically free under its weight and the vertical load;
# the ballast's reaction is recorded per face. Irazábal (2017) §6.4 (Tables 6.6, 6.7); lab: van 't Zand & Moraal (1997).
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (the endpoint is unused).
import json
import math
import os
import sys
import time

import numpy as np
from yade import pack as yade_pack

from railcosim import bedcache, results, track

parameters_path, _, out = sys.argv[1:4]
with open(parameters_path) as f:
    p = json.load(f)
sys.path.insert(0, p["case_dir"])
import bed_geometry  # noqa: E402  (the case folder's: the bed's profile, shared with case.py)

wall_start = time.monotonic()

# 1. Geometry (m). x: along the sleeper (the push), y: along the track, z: up; z = 0 is the concrete slab.
L, B, H = p["sleeper_length"], p["sleeper_width"], p["sleeper_height"]
depth = p["ballast_depth"]                          # ballast under the sleeper
crest = bed_geometry.crest(p)                       # ballast surface: crib and shoulder, level with the sleeper top
half_y = 0.5 * p["sleeper_spacing"]                 # mirror walls halfway to the next sleepers


def profile_x(z):
    """Outer edge of the bed at height z (bed_geometry.profile_x)."""
    return float(bed_geometry.profile_x(p, z))


x_box = profile_x(0.0) + 0.05                       # packing box (end walls) a little beyond the toe of the slope

# 2. Materials: the pre-calculation's frictionless set (Table 6.6: mu = 0, eta_r = 0) and the test's (Table 6.7).
def ballast_material(friction, rolling, young):
    return BallastMat(young=young, poisson=p["ballast_poisson"], density=p["ballast_density"],
                      frictionAngle=math.atan(friction), restitution=p["restitution"], rollingFriction=rolling)


def surface_material(young, friction, rolling):
    return BallastMat(young=young, poisson=0.2, density=1000.0, frictionAngle=math.atan(friction),
                      restitution=p["restitution"], rollingFriction=rolling)


packing = [O.materials.append(m) for m in (
    ballast_material(0.0, 0.0, p["packing_young"]), surface_material(p["sleeper_young"], 0.0, 0.0),
    surface_material(p["slab_young"], 0.0, 0.0), surface_material(p["mirror_young"], 0.0, 0.0))]
test = [O.materials.append(m) for m in (
    ballast_material(p["ballast_friction"], p["rolling_friction"], p["ballast_young"]),
    surface_material(p["sleeper_young"], p["sleeper_friction"], p["wall_rolling_friction"]),
    surface_material(p["slab_young"], p["sleeper_friction"], p["wall_rolling_friction"]),
    surface_material(p["mirror_young"], 0.0, p["wall_rolling_friction"]))]
BALLAST, SLEEPER, SLAB, MIRROR = range(4)

# 3. Boundaries: the slab and the mirror walls (frictionless: the neighbouring sleepers' bed by symmetry); end walls
# for the packing only (pack_bed).
slab = O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=packing[SLAB]))
mirrors = [O.bodies.append(utils.wall(position=s * half_y, axis=1, sense=-s, material=packing[MIRROR])) for s in (-1, 1)]

# 4. Grading EN 13450 (Irazábal Table 2.1, mid-points of the passing bands), diameters scaled by size_scale, and the
# grading's mean sphere volume (mass fractions per band, each band at its mid diameter).
sizes, passing, mean_volume = track.grading(p["size_scale"])
r_max = 0.5 * sizes[-1]
CLOUD_SOLID_FRACTION = 0.3  # random placement jams near 0.38; the bed settles to about 0.6


def rain(z_low, z_high, seed, keep=lambda c, r: True):
    """A loose cloud of spheres of the grading in the box between z_low and z_high, minus those `keep` rejects."""
    sp = yade_pack.SpherePack()
    low, high = (-x_box, -half_y, z_low), (x_box, half_y, z_high)  # the spheres lie inside it
    volume = (2 * x_box) * (2 * half_y) * (z_high - z_low)
    sp.makeCloud(low, high, psdSizes=sizes, psdCumm=passing, distributeMass=True,
                 num=int(CLOUD_SOLID_FRACTION * volume / mean_volume), seed=seed)
    return [O.bodies.append(utils.sphere(c, r, material=packing[BALLAST])) for c, r in sp if keep(c, r)]


O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb(), Bo1_Wall_Aabb()], label="collider"),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
    BoundedRollingFrictionEngine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81), label="newton"),
]


def settle(seconds):
    O.run(max(1, int(seconds / O.dt)), True)


# 5. Pre-calculation (Irazábal §6.4.2, gravitational packing without friction): the layer under the held sleeper,
# cut flat at the sleeper's bottom; crib and shoulders rained around it; the bed cut to its profile. The packed bed
# depends only on the geometry, the grading and the packing settings: kept in the cache and reused by runs that
# differ in load, push or test contact parameters.
# The sleeper is held above the packing box until the layer under it is made (YADE's collider missed a body added
# after spheres had been erased).
sleeper_mass = p["sleeper_mass"]
sleeper = O.bodies.append(utils.box(center=(0, 0, 10.0), extents=(0.5 * L, 0.5 * B, 0.5 * H),
                                    material=packing[SLEEPER], fixed=True))
PACKING_KEYS = ("sleeper_length", "sleeper_width", "sleeper_height", "sleeper_spacing", "ballast_depth",
                "shoulder_width", "shoulder_slope", "crest_drop_m", "size_scale", "packing_young", "ballast_poisson",
                "ballast_density", "restitution", "settle_s", "dt_safety", "seed")
cache = bedcache.path("lateral_resistance", {k: p[k] for k in PACKING_KEYS}, fallback=os.path.join(out, "cache"))


def pack_bed():
    """The packed bed: sphere centres and radii, and the height of the sleeper's centre resting on it."""
    ends = [O.bodies.append(utils.wall(position=s * x_box, axis=0, sense=-s, material=packing[MIRROR]))
            for s in (-1, 1)]
    spheres = rain(0.0, 2.0 * depth + 2 * r_max, p["seed"])
    O.dt = p["dt_safety"] * utils.PWaveTimeStep()
    settle(p["settle_s"])
    for i in spheres:
        b = O.bodies[i]
        if b.state.pos[2] + b.shape.radius > depth:
            O.bodies.erase(i)
    spheres = [i for i in spheres if O.bodies[i] is not None]
    O.bodies[sleeper].state.pos = Vector3(0, 0, depth + 0.5 * H)
    O.engines[1].doSort = True  # the collider
    inside = lambda c, r: not (abs(c[0]) < 0.5 * L + r and abs(c[1]) < 0.5 * B + r)
    spheres += rain(depth, depth + 2.2 * H + 2 * r_max, p["seed"] + 1, inside)
    settle(p["settle_s"])
    for i in spheres:
        c = O.bodies[i].state.pos
        if c[2] > crest or abs(c[0]) > profile_x(c[2]):
            O.bodies.erase(i)
    spheres = [i for i in spheres if O.bodies[i] is not None]
    for i in ends:
        O.bodies.erase(i)
    bed = np.array([[*O.bodies[i].state.pos, O.bodies[i].shape.radius] for i in spheres])
    # The sleeper lowered onto the highest grain under it (the cut left a gap), so that it does not fall onto it.
    under = (np.abs(bed[:, 0]) < 0.5 * L) & (np.abs(bed[:, 1]) < 0.5 * B) & (bed[:, 2] < depth)
    return spheres, bed, float(np.max(bed[under, 2] + bed[under, 3]) + 0.5 * H)


with bedcache.exclusive(cache) as found:
    if found:
        with np.load(cache) as saved:
            bed, sleeper_z = saved["bed"], float(saved["sleeper_z"])
        spheres = [O.bodies.append(utils.sphere(row[:3], row[3], material=packing[BALLAST])) for row in bed]
        print(f"packed bed from {cache}", flush=True)
    else:
        spheres, bed, sleeper_z = pack_bed()
        partial = f"{cache}.{os.getpid()}.npz"
        np.savez(partial, bed=bed, sleeper_z=sleeper_z)
        os.replace(partial, cache)  # whole or not at all
O.bodies[sleeper].state.pos = Vector3(0, 0, sleeper_z)
O.engines[1].doSort = True  # the collider

# 6. The test's materials (friction, rolling friction); contacts made anew with them. The sleeper becomes free
# vertically (its weight and the vertical load) and held in the other directions; the bed settles under it.
for i in spheres:
    O.bodies[i].material = O.materials[test[BALLAST]]
O.bodies[sleeper].material = O.materials[test[SLEEPER]]
O.bodies[slab].material = O.materials[test[SLAB]]
for i in mirrors:
    O.bodies[i].material = O.materials[test[MIRROR]]
O.interactions.clear()
O.engines[1].doSort = True  # the collider
s = O.bodies[sleeper]
s.dynamic = True
# The vertical load as added mass, as in the lab (concrete slabs of 9.95 kN laid on the rails, §6.4.4): the push is
# imposed, so the mass acts only through its weight and the sleeper's vertical inertia.
s.state.mass = sleeper_mass + p["vertical_load_N"] / 9.81
s.state.blockedDOFs = "xyXYZ"
s.state.vel = Vector3(0, 0, 0)
mu_sleeper = p["sleeper_friction"]


def sleeper_friction():
    """The pair rule takes the smaller friction of two materials (docs/contact-models.md); Table 6.7's ballast-sleeper
    contact has mu = 0.7247 (measured by van 't Zand & Moraal), above the ballast's 0.6: set on the sleeper's contacts."""
    for i in O.bodies[sleeper].intrs():
        if i.phys and i.phys.tangensOfFrictionAngle != mu_sleeper:
            i.phys.tangensOfFrictionAngle = mu_sleeper


import __main__
__main__.lateral_sleeper_friction = sleeper_friction  # PyRunner commands run in __main__
O.engines = O.engines + [PyRunner(command="lateral_sleeper_friction()", iterPeriod=p["friction_every"], label="friction")]
solid = sum(4.0 / 3.0 * math.pi * O.bodies[i].shape.radius ** 3 for i in spheres)
O.dt = p["dt_safety"] * utils.PWaveTimeStep()
settle(p["rest_s"])
settled = time.monotonic() - wall_start
bed_at_start = np.array([[*O.bodies[i].state.pos, O.bodies[i].shape.radius] for i in spheres])
z0 = s.state.pos[2]
print(f"{len(spheres)} spheres (d {sizes[0] * 1e3:.0f}-{sizes[-1] * 1e3:.0f} mm), bed settled in {settled:.0f} s; "
      f"sleeper sank {(depth + 0.5 * H - z0) * 1e3:.1f} mm; dt {O.dt:.2e} s", flush=True)

# 7. Forces on the sleeper per face, from its contacts: base, sides (crib), ends (shoulder), top.
FACES = ("base", "sides", "shoulder", "top")


def face_forces():
    """{face: force of the ballast on the sleeper [N]}, from each contact's normal; "base_shear": the base contacts'
    tangential forces alone, and "base_normal" (x: the sum of their normal forces' magnitudes), for the Coulomb bound
    |F_t| <= mu |F_n|, which holds per contact and so for any sum."""
    c = s.state.pos
    sums = {f: np.zeros(3) for f in FACES + ("base_shear", "base_normal")}
    for i in s.intrs():
        if not i.isReal:
            continue
        sign = -1.0 if i.id1 == sleeper else 1.0  # the phys forces act on body 2
        normal, shear = sign * i.phys.normalForce, sign * i.phys.shearForce
        f = normal + shear
        # The face is the one the contact pushes on: the dominant component of the contact normal (a grain on an edge
        # counts with the face it presses most; a face's own contacts have its normal exactly).
        n = i.geom.normal
        axis = int(np.argmax((abs(n[0]), abs(n[1]), abs(n[2]))))
        face = ("shoulder", "sides", "base" if i.geom.contactPoint[2] < c[2] else "top")[axis]
        sums[face] += (f[0], f[1], f[2])
        if face == "base":
            sums["base_shear"] += (shear[0], shear[1], shear[2])
            sums["base_normal"][0] += normal.norm()
    return sums


# 8. The push: displacement-controlled at push_velocity to push_distance; force averaged over each record.
v = p["push_velocity"]
steps = int(round(p["push_distance"] / (v * O.dt)))
per_record = max(1, int(round(p["record_every_m"] / (v * O.dt))))
sample = max(1, per_record // p["samples_per_record"])
x0 = s.state.pos[0]
recorder = results.DemRecorder(out)
acc = {f: np.zeros(3) for f in FACES + ("base_shear", "base_normal")}
count = 0
vz_start = s.state.vel[2]
s.state.vel = Vector3(v, 0, vz_start)
push_start = time.monotonic()
t0 = O.time
for k in range(0, steps, sample):
    O.run(min(sample, steps - k), True)
    for f, value in face_forces().items():
        acc[f] += value
    count += 1
    if (k + sample) % per_record < sample or k + sample >= steps:
        mean = {f: acc[f] / count for f in acc}
        total = sum(mean[f] for f in FACES)
        recorder.append(time=O.time - t0, displacement=s.state.pos[0] - x0, lateral_force=-total[0],
                        **{f"{f}_lateral_force": -mean[f][0] for f in FACES},
                        base_normal_force=mean["base"][2], vertical_reaction=total[2],
                        base_shear_lateral_force=-mean["base_shear"][0], base_normal_magnitude=mean["base_normal"][0],
                        settlement=z0 - s.state.pos[2], sleeper_velocity_z=s.state.vel[2],
                        kinetic_energy=utils.kineticEnergy())
        acc = {f: np.zeros(3) for f in acc}
        count = 0
        last = recorder.last
        if len(recorder) % max(1, p["progress_every"]) == 0:
            print(f"u={last['displacement'] * 1e3:.2f} mm  F={last['lateral_force'] / 1e3:.2f} kN  (base "
                  f"{last['base_lateral_force'] / 1e3:.2f}, sides {last['sides_lateral_force'] / 1e3:.2f}, shoulder "
                  f"{last['shoulder_lateral_force'] / 1e3:.2f})  {time.monotonic() - push_start:.0f} s", flush=True)

# 9. What the post-processing reads.
info = {"spheres": len(spheres), "dt": O.dt, "steps": O.iter, "push_steps": steps,
        "wall_time_s": time.monotonic() - wall_start, "packing_wall_time_s": settled,
        "push_wall_time_s": time.monotonic() - push_start, "sleeper_mass_kg": sleeper_mass,
        "sleeper_weight_n": sleeper_mass * 9.81, "loaded_mass_kg": s.state.mass, "solid_volume_m3": solid,
        "diameters_m": [sizes[0], sizes[-1]], "sleeper_sink_m": depth + 0.5 * H - z0,
        "sleeper_velocity_z_start": vz_start, "packed_bed": cache}
bed = np.array([[*O.bodies[i].state.pos, O.bodies[i].shape.radius] for i in spheres])
results.save_dem_outputs(out, recorder, info, bed_spheres=bed, bed_spheres_at_start=bed_at_start, sleeper_centre=np.array(s.state.pos))
print(f"done: {steps} push steps in {info['push_wall_time_s']:.0f} s, {info['wall_time_s']:.0f} s in all", flush=True)
