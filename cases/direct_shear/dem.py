# YADE participant of the direct shear case (DEM only): sphere-cluster ballast deposited in a split box, loaded by a
# free plate and sheared by moving the lower half, once per normal stress from the same packed sample.
# Irazábal (2017) §6.3 (Tables 6.3, 6.4); laboratory test: Indraratna et al. (2011).
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (the endpoint is unused).
import json
import math
import os
import sys
import time

import numpy as np

from railcosim import bedcache
from railcosim.dem import StandaloneDem

dem = StandaloneDem()
p = dem.parameters
out = dem.out
GRAVITY = 9.81
# YADE runs this file without its folder on the path
sys.path[:0] = [os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"), p["case_dir"]]
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402
import shear_box  # noqa: E402

wall_start = time.monotonic()
stresses, sieves, passing = shear_box.settings(p)

# 1. Geometry (m): shear_box.dimensions.
L, B, H, split, t, solid_volume = shear_box.dimensions(p)

# 2. Materials (Table 6.3). Deposition (the pre-calculation, §6.3.2): ballast with mu0, frictionless walls. Test:
#    walls and plate mu = 0.6 (steel); ballast mu0, constant or stress-dependent between different stones (Table 6.4;
#    Law2_ScGeom_BallastPhys_Ballast applies it only between members of different clumps, the walls keep mu0).
sdf = p["friction_model"] == "stress_dependent"


def material(young, friction, exponent=0.0, stress=0.0):
    return O.materials.append(BallastMat(young=young, poisson=p["ballast_poisson"], density=p["ballast_density"],
                                         frictionAngle=math.atan(friction), restitution=p["restitution"],
                                         rollingFriction=0.0, frictionExponent=exponent, maxContactStress=stress))


def materials():
    """The deposition's and the test's materials, as ids in O.materials: made anew after each O.load (a loaded scene
    brings the materials it was saved with)."""
    ids = [material(p["ballast_young"], p["ballast_friction"]), material(p["wall_young"], 0.0),
           material(p["ballast_young"], p["ballast_friction"], p["friction_exponent"] if sdf else 0.0,
                    p["max_contact_stress"] if sdf else 0.0),
           material(p["wall_young"], p["wall_friction"])]
    return ids


fill_ballast, fill_wall, test_ballast, test_wall = materials()

# 3. Stones: library clusters drawn to the grading until the solid volume of the void ratio is reached.
rng = np.random.default_rng(p["seed"])
library = ballast_clusters.loadShapeLibrary()
stones = ballast_clusters.sampleBallastStones(library, rng, solid_volume, level=p["cluster_level"],
                                              density=p["ballast_density"], targetPassing=passing, sieves=sieves)
stone_volume = sum(s["mass"] for s in stones) / p["ballast_density"]
reaches = np.array([s["enclosingRadius"] for s in stones])


# 4. The box: lower half (floor, end and side walls; moves along x), upper half (fixed), loading plate (free along z).
def box(lo, hi, mat):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return O.bodies.append(utils.box(center=tuple(0.5 * (lo + hi)), extents=tuple(0.5 * (hi - lo)), fixed=True,
                                     material=mat, wire=True))


def build_box(column_top):
    lower = [box((-t, -t, -t), (L + t, B + t, 0.0), fill_wall),                 # floor
             box((-t, -t, 0.0), (0.0, B + t, split), fill_wall),               # end walls
             box((L, -t, 0.0), (L + t, B + t, split), fill_wall),
             box((0.0, -t, 0.0), (L, 0.0, split), fill_wall),                  # side walls
             box((0.0, B, 0.0), (L, B + t, split), fill_wall)]
    upper = [box((-t, -t, split), (0.0, B + t, column_top), fill_wall),
             box((L, -t, split), (L + t, B + t, column_top), fill_wall),
             box((0.0, -t, split), (L, 0.0, column_top), fill_wall),
             box((0.0, B, split), (L, B + t, column_top), fill_wall)]
    return lower, upper


KEYS = ("box_length", "box_width", "box_height", "shear_distance", "grading_sieves_mm", "grading_passing", "size_scale",
        "void_ratio", "cluster_level", "ballast_young", "ballast_poisson", "ballast_density", "ballast_friction",
        "wall_young", "restitution", "fill_dt", "fill_s", "rest_speed", "packing_damping", "seed")
cache = bedcache.path("direct_shear", {k: p[k] for k in KEYS}, name="sample", suffix=".yade.gz",
                      fallback=os.path.join(out, "cache"))


def engines(damping):
    return [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()], label="collider"),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                        [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
        QuaternionIntegrator(scheme="zhaoVanWachem", damping=damping, gravity=(0, 0, -GRAVITY), label="integrator"),
    ]


# 5. Pre-calculation (Irazábal §6.3.2, Fig. 6.10): the loose cloud falls into the box and comes to rest; kept in the
#    cache (the whole scene) and reused by every normal stress and by runs that differ only in the test's settings.
fill_wall_time = 0.0
with bedcache.exclusive(cache) as found:
    if found:
        # A scene saved by another build of the plugins may not load (a class that gained an attribute): the sample
        # is then prepared again and the cache replaced, rather than the run failing on a stale file.
        try:
            O.load(cache)
            with open(cache + ".json") as f:
                ids = json.load(f)
            print(f"packed sample from {cache}", flush=True)
        except (RuntimeError, OSError, ValueError) as error:
            print(f"cached sample {cache} unreadable by this build ({error}); preparing it again", flush=True)
            O.reset()  # a failed load leaves the scene half replaced
            fill_ballast, fill_wall, test_ballast, test_wall = materials()
            found = False
    if not found:
        centres, column_top = shear_box.place(p, reaches, rng)
        lower, upper = build_box(column_top + 0.05)
        clumps = [pack_ballast.addClusterStone(s, c, O.materials[fill_ballast]) for s, c in zip(stones, centres)]
        O.engines = engines(p["packing_damping"])
        O.dt = p["fill_dt"]
        start = time.monotonic()
        # Until every stone is slower than rest_speed (checked every 0.05 s), fill_s at most.
        chunk = max(1, int(round(0.05 / O.dt)))
        while O.time < p["fill_s"]:
            O.run(chunk, True)
            fastest = max(O.bodies[c].state.vel.norm() for c in clumps)
            if fastest < p["rest_speed"]:
                break
        print(f"deposition: {O.time:.2f} s simulated, fastest stone {fastest:.3f} m/s", flush=True)
        fill_wall_time = time.monotonic() - start
        ids = {"lower": lower, "upper": upper, "clumps": clumps, "fill_wall_time_s": fill_wall_time}
        partial = f"{cache}.{os.getpid()}"
        O.save(partial + ".yade.gz")
        with open(partial + ".json", "w") as f:
            json.dump(ids, f)
        os.replace(partial + ".json", cache + ".json")
        os.replace(partial + ".yade.gz", cache)
        print(f"deposited in {fill_wall_time:.0f} s", flush=True)
lower, upper, clumps = ids["lower"], ids["upper"], ids["clumps"]
members = [b.id for b in O.bodies if b.isClumpMember]
print(f"{len(clumps)} stones ({len(members)} spheres, sieve {sieves[0]:.1f}-{sieves[-1]:.1f} mm), solid volume "
      f"{stone_volume:.5f} m3 (target {solid_volume:.5f})", flush=True)


def top_of_sample():
    return max(O.bodies[i].state.pos[2] + O.bodies[i].shape.radius for i in members)


def force_x(bodies):
    return sum(O.forces.f(i)[0] for i in bodies)


def contact_force(body):
    """The ballast's force on a body, summed over its contacts (the plate also carries a permanent force)."""
    total = np.zeros(3)
    for i in O.bodies[body].intrs():
        if i.isReal:
            f = i.phys.normalForce + i.phys.shearForce  # on body 2
            total += np.array(-f if i.id1 == body else f)
    return total


def hertz_friction_check():
    """The stress-dependent friction in the loaded packing, contact by contact between different stones: the law's
    mu against the thesis' mu0 min(1, p0/sigma_c,max)^gamma with Hertz's peak pressure p0 = (2/pi) E* sqrt(delta/R*)
    (eqs. 6.3-6.6 through the closed form, not the law's F_n/F_n,c). The law takes the total normal force (elastic and
    viscous, erratum 7): the comparison keeps the quasi-static contacts, whose force is Hertz's elastic
    (4/3) E* sqrt(R*) delta^1.5 within 1 %. Returns the largest relative deviation, the share of those contacts the
    law reduces, their mean mu, their number and the number of contacts between stones."""
    mu0, gamma, limit = p["ballast_friction"], p["friction_exponent"], p["max_contact_stress"]
    young = p["ballast_young"] / (2.0 * (1.0 - p["ballast_poisson"] ** 2))  # E* of two like stones
    worst, reduced, mus, total = 0.0, 0, [], 0
    for i in O.interactions:
        b1, b2 = O.bodies[i.id1], O.bodies[i.id2]
        if not (i.isReal and b1.isClumpMember and b2.isClumpMember and b1.clumpId != b2.clumpId):
            continue
        r = b1.shape.radius * b2.shape.radius / (b1.shape.radius + b2.shape.radius)
        delta = i.geom.penetrationDepth
        if delta <= 0.0:
            continue
        total += 1
        elastic = 4.0 / 3.0 * young * math.sqrt(r) * delta ** 1.5
        if abs(i.phys.normalForce.norm() / elastic - 1.0) > 0.01:
            continue
        p0 = 2.0 / math.pi * young * math.sqrt(delta / r)
        expected = mu0 * min(1.0, limit / p0) ** (-gamma)
        worst = max(worst, abs(i.phys.frictionCoeff - expected) / expected)
        reduced += expected < mu0
        mus.append(i.phys.frictionCoeff)
    return worst, reduced / max(1, len(mus)), float(np.mean(mus)) if mus else mu0, len(mus), total


# 6. One shear test per normal stress, each from the packed sample: the test's materials, the plate on the sample,
#    its load, rest, then the lower half moves at shear_velocity to shear_distance.
v = p["shear_velocity"]
tests = []
for n, sigma in enumerate(stresses):
    if n:
        O.load(cache)
    fill_ballast, fill_wall, test_ballast, test_wall = materials()
    for i in members:
        O.bodies[i].material = O.materials[test_ballast]
    for i in lower + upper:
        O.bodies[i].material = O.materials[test_wall]
    O.interactions.clear()
    O.engines = engines(p["packing_damping"])  # the rest under load settles with numerical damping, the shear without
    O.dt = p["dem_dt"]
    area = L * B
    load = sigma * area  # the plate's weight and the added force: sigma_n over the whole box
    clearance = 1e-3
    z0 = top_of_sample()
    plate = O.bodies.append(utils.box(center=(0.5 * L, 0.5 * B, z0 + 0.01), extents=(0.5 * L - clearance,
                                      0.5 * B - clearance, 0.01), fixed=False, material=O.materials[test_wall], wire=True))
    pb = O.bodies[plate]
    pb.state.mass = p["plate_mass"]
    O.engines[1].doSort = True
    # The plate comes down at approach_velocity (imposed) until the ballast carries the load, then is free vertically
    # under its weight and the added force (sigma_n over the box) while the sample rests.
    start = time.monotonic()
    pb.dynamic = False
    pb.state.vel = Vector3(0, 0, -p["approach_velocity"])
    chunk = max(1, int(round(2e-4 / p["approach_velocity"] / O.dt)))  # 0.2 mm of approach
    while contact_force(plate)[2] < load:
        O.run(chunk, True)
        if pb.state.pos[2] < 0.25 * H:
            raise RuntimeError("direct_shear: the plate went down to a quarter of the box without meeting the sample")
    pb.dynamic = True
    pb.state.vel = Vector3(0, 0, 0)
    pb.state.mass = p["plate_mass"]
    pb.state.blockedDOFs = "xyXYZ"
    O.forces.setPermF(plate, Vector3(0, 0, -(load - p["plate_mass"] * GRAVITY)))
    O.run(max(1, int(round(p["rest_s"] / O.dt))), True)
    O.engines = engines(0.0)
    rest_wall = time.monotonic() - start
    check = hertz_friction_check() if sdf else None
    h0 = pb.state.pos[2] - 0.01  # plate bottom: the sample's height
    void_ratio = L * B * h0 / stone_volume - 1.0
    print(f"sigma_n {sigma / 1e3:g} kPa: rested {rest_wall:.0f} s, sample height {h0 * 1e3:.1f} mm, void ratio "
          f"{void_ratio:.3f}" + (f"; friction law: worst {check[0]:.2e} over {check[3]} quasi-static contacts of "
                                 f"{check[4]}, {100 * check[1]:.0f} % reduced, mean mu {check[2]:.3f}" if check else ""),
          flush=True)
    momentum_start = sum(O.bodies[c].state.mass * O.bodies[c].state.vel[0] for c in clumps)
    for i in lower:
        O.bodies[i].state.vel = Vector3(v, 0, 0)
    x0 = O.bodies[lower[0]].state.pos[0]
    t0 = O.time
    acc = {}

    def sample():
        on_plate = contact_force(plate)
        values = {"upper_force_x": force_x(upper) + on_plate[0], "lower_force_x": force_x(lower),
                  "plate_contact_force_z": on_plate[2],
                  "upper_ballast_weight": GRAVITY * sum(O.bodies[c].state.mass for c in clumps
                                                        if O.bodies[c].state.pos[2] > split)}
        for k, value in values.items():
            acc[k] = acc.get(k, 0.0) + value
        acc["count"] = acc.get("count", 0) + 1

    def record():
        count = max(1, acc.pop("count", 1))
        mean = {k: value / count for k, value in acc.items()}
        acc.clear()
        u = O.bodies[lower[0]].state.pos[0] - x0
        contact_area = B * (L - u)  # Irazábal eqs. 6.1-6.2
        normal = load + mean.get("upper_ballast_weight", 0.0)
        return {"shear_displacement": u, "shear_force": mean.get("upper_force_x", 0.0),
                "lower_force_x": mean.get("lower_force_x", 0.0), "normal_force": normal,
                "shear_stress": mean.get("upper_force_x", 0.0) / contact_area, "normal_stress": normal / contact_area,
                "plate_contact_force_z": mean.get("plate_contact_force_z", 0.0), "applied_load": load,
                "dilation": pb.state.pos[2] - 0.01 - h0, "kinetic_energy": utils.kineticEnergy(),
                "momentum_x": sum(O.bodies[c].state.mass * O.bodies[c].state.vel[0] for c in clumps),
                "normal_stress_applied": sigma}

    steps = int(round(p["shear_distance"] / (v * O.dt)))
    per_record = max(1, int(round(p["record_every_m"] / (v * O.dt))))
    every = max(1, per_record // p["samples_per_record"])
    import __main__
    __main__.direct_shear_sample = sample  # PyRunner commands run in __main__
    O.engines = O.engines + [PyRunner(command="direct_shear_sample()", iterPeriod=every)]
    first = len(dem.recorder) if dem.recorder is not None else 0
    start = time.monotonic()
    dem.run(steps * O.dt, record, per_record * O.dt,
            progress=lambda last: f"sigma_n {sigma / 1e3:g} kPa  u={last['shear_displacement'] * 1e3:.1f} mm  "
                                  f"tau={last['shear_stress'] / 1e3:.1f} kPa  dh={last['dilation'] * 1e3:.2f} mm")
    tests.append({"normal_stress_Pa": sigma, "first_record": first, "momentum_x_start": momentum_start, "records": len(dem.recorder) - first,
                  "sample_height_m": h0, "void_ratio": void_ratio, "rest_wall_time_s": rest_wall,
                  "shear_wall_time_s": time.monotonic() - start, "shear_steps": steps, "spheres": len(members),
                  "friction_check": None if check is None else {"worst_relative_deviation": check[0],
                                                                "reduced_share": check[1], "mean_mu": check[2],
                                                                "contacts": check[3], "all_contacts": check[4]}})

dem.save(stones=len(clumps), spheres=len(members), solid_volume_m3=stone_volume, target_solid_volume_m3=solid_volume,
         sieves_mm=list(sieves), tests=tests, fill_wall_time_s=ids.get("fill_wall_time_s", 0.0),
         fill_this_run_s=fill_wall_time, total_wall_time_s=time.monotonic() - wall_start, packed_sample=cache)
