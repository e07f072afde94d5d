"""Benchmark: cost per stone-step of railcosim's cluster path against stock YADE clumps with Hertz-Mindlin.

USAGE:   ./railcosim yade [-jN] benchmarks/cluster_cost.py [--stones 500] [--steps 600] [--repeats 3] [--bed FILE]
         [--json PATH]   (`./railcosim bench clusters` runs it with one and with two OpenMP threads on one bed)
OUTPUTS: a table (wall and CPU µs per stone-step and their ratios to stock YADE, CPU µs per sphere-step, contacts per
         stone, the engines' µs per stone-step); JSON records only with --json, merged by thread count into that file.

Bed: library sphere clusters (yade_engines/clusters, "coarse": 8-15 spheres per stone, as the beam case's
particle_shape = "cluster"), sieve sizes uniform in [0.85, 1.15] x --size, principal axes on a box lattice with random
half turns, dropped into a square box (frictional floor, frictionless side walls, so that the floor carries the whole
weight) and settled once on the railcosim path (frictionless deposition, then with friction, damped, then undamped;
or read from --bed). That state is kept; each timed run restores it, clears the contacts (every path starts its
contact histories afresh), puts its own materials on the bodies and its own engines in place, runs --warmup steps,
then --steps timed steps, then samples the floor force over --sample steps. The paths, in the same scene, time step,
gravity and thread count:
  railcosim       QuaternionIntegrator (Zhao-van Wachem) + BallastMat + Law2_ScGeom_BallastPhys_Ballast, smooth
                  Hertz-Mindlin with Thornton damping from e (docs/contact-models.md);
  railcosim_full  the same with Pohrt-Popov plastic normal law, stress-dependent friction and a rolling arm (the sub-
                  models the law can switch on; BoundedRollingFrictionEngine acts on standalone spheres only, never on
                  clumps, so it has no part in a cluster bed);
  stock           NewtonIntegrator + FrictMat + Ip2_FrictMat_FrictMat_MindlinPhys(en = es = e) +
                  Law2_ScGeom_MindlinPhys_Mindlin.
The repetitions run the paths in turn, so that each ratio compares runs taken under the same machine load.
Physics check (not timing): for each run the floor force minus the weight must equal the rate of change of the bed's
vertical momentum and the floor force must be the weight, and the mean stone height must agree between railcosim and
stock (limits below); a mismatch is reported and the script exits with status 1 after writing its records. Timing
never fails it.
"""
import argparse
import datetime
import json
import math
import os
import random
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"))
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--stones", type=int, default=500)
parser.add_argument("--size", type=float, default=0.04, help="mean sieve size [m]")
parser.add_argument("--box", type=float, default=0.3, help="side of the square box [m]")
parser.add_argument("--steps", type=int, default=600, help="timed steps per run")
parser.add_argument("--warmup", type=int, default=200, help="steps after the restore, not timed")
parser.add_argument("--sample", type=int, default=200, help="steps over which the floor force is averaged")
parser.add_argument("--repeats", type=int, default=3)
parser.add_argument("--seed", type=int, default=1)
parser.add_argument("--bed", default=None, help="settled bed file (.yade.gz): read if there, else written")
parser.add_argument("--json", default=None, help="merge the records into this file (none by default)")
args = parser.parse_args(sys.argv[1:])

young, poisson, density, friction, restitution = 1e8, 0.25, 2600.0, 0.6, 0.3
gravity = 9.81
level = "coarse"
# Physics limits. Momentum balance: over the sampled steps the floor's mean upward force minus the weight equals the
# rate of change of the bed's vertical momentum (the side walls are frictionless and push horizontally only). Both
# integrators advance the stored velocities by dt F/m per step, so the balance telescopes exactly (measured 1e-15 of
# the weight); 1e-6 leaves room for round-off in the sums and flags any lost or spurious force (a wall holding stones
# by friction, a contact counted on one side only). Floor force = weight: after the restore the bed re-forms its
# contacts with fresh tangential histories and slumps by a fraction of an overlap; what is left of that after --warmup
# and --steps (the momentum rate) stays within 3 % of the weight (measured 0.3 % on the default bed, 2.1 % on the
# shallow 60-stone bed of the smoke test after 500 steps). Mean height: the two laws share Hertz's normal and
# Mindlin's tangential stiffness (walls too: Ig2_Wall_Sphere_ScGeom(hertzian=True) gives the stock Ip2 a wall radius
# of 1e8 sphere radii, where the railcosim law takes a wall as flat) and Thornton's damping ratio, and differ in the
# dashpots' mass (stock: the member sphere's, railcosim: the clump's), so the re-settled beds may differ by a little
# rearrangement; 2 % of a stone size is far below a change of packing.
MOMENTUM_TOLERANCE = 1e-6
FLOOR_FORCE_TOLERANCE = 0.03
HEIGHT_TOLERANCE = 0.02

threads = O.numThreads
rng = random.Random(args.seed)
library = ballast_clusters.loadShapeLibrary()
templates = [(s["clusters"][level]["spheres"], s["clusters"][level]["volume"], s["clusters"][level]["principalInertia"])
             for s in library["shapes"]]
extent_of = [np.max(np.abs(t[0][:, :3]) + t[0][:, 3:4], axis=0) for t in templates]


def build_bed():
    """Stones on a box lattice above the floor (long axes along y, random half turns), walls; returns clump ids."""
    O.reset()
    mat = O.materials.append(BallastMat(young=young, poisson=poisson, density=density,
                                        frictionAngle=math.atan(friction), restitution=restitution, label="stones"))
    wall_mat = O.materials.append(BallastMat(young=young, poisson=poisson, density=density, frictionAngle=0.0,
                                             restitution=restitution, label="walls"))
    floor = O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=mat))
    side = args.box
    for axis, position, sense in ((0, 0.0, 1), (0, side, -1), (1, 0.0, 1), (1, side, -1)):
        O.bodies.append(utils.wall(position=position, axis=axis, sense=sense, material=wall_mat))
    sizes = [args.size * rng.uniform(0.85, 1.15) for _ in range(args.stones)]
    kinds = [rng.randrange(len(templates)) for _ in range(args.stones)]
    half = np.max([extent_of[k][[1, 0, 2]] * d for k, d in zip(kinds, sizes)], axis=0) * 1.05
    nx, ny = int(side / (2 * half[0])), int(side / (2 * half[1]))
    if nx < 1 or ny < 1:
        raise ValueError(f"cluster_cost: box {side} m is narrower than one stone")
    across = Quaternion((0, 0, 1), 0.5 * math.pi)
    half_turns = [Quaternion.Identity, Quaternion((1, 0, 0), math.pi), Quaternion((0, 1, 0), math.pi),
                  Quaternion((0, 0, 1), math.pi)]
    clumps = []
    for k, (kind, size) in enumerate(zip(kinds, sizes)):
        layer, cell = divmod(k, nx * ny)
        i, j = divmod(cell, ny)
        centre = (side * (i + 0.5) / nx, side * (j + 0.5) / ny, half[2] * (2 * layer + 1) + 0.002)
        turn = across * half_turns[rng.randrange(4)]
        rotation = np.array([[turn.toRotationMatrix()[a, b] for b in range(3)] for a in range(3)])
        spheres, unit_volume, inertia = templates[kind]
        stone = {"rotation": rotation, "spheres": spheres * size, "mass": density * unit_volume * size ** 3,
                 "principalInertia": density * inertia * size ** 5}
        clumps.append(pack_ballast.addClusterStone(stone, centre, O.materials[mat]))
    return floor, clumps, min(sizes)


def railcosim_engines(damping, g):
    return [ForceResetter(),
            InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=True)],
                            [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
            QuaternionIntegrator(damping=damping, gravity=(0, 0, -g), scheme="zhaoVanWachem")]


def stock_engines():
    return [ForceResetter(),
            InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=True)],
                            [Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=restitution),
                                                               es=MatchMaker(algo="val", val=restitution))],
                            [Law2_ScGeom_MindlinPhys_Mindlin()]),
            NewtonIntegrator(damping=0.0, gravity=(0, 0, -gravity))]


# The paths: (materials for stones and side walls, engines).
PATHS = {
    "railcosim": (lambda fa: BallastMat(young=young, poisson=poisson, density=density, frictionAngle=fa,
                                        restitution=restitution),
                  lambda: railcosim_engines(0.0, gravity)),
    "railcosim_full": (lambda fa: BallastMat(young=young, poisson=poisson, density=density, frictionAngle=fa,
                                             restitution=restitution, roughnessFractalDim=2.2, roughnessRms=2e-6,
                                             plasticUnloading=True, frictionExponent=-0.1, maxContactStress=5e6,
                                             rollingFriction=0.2),
                       lambda: railcosim_engines(0.0, gravity)),
    "stock": (lambda fa: FrictMat(young=young, poisson=poisson, density=density, frictionAngle=fa),
              stock_engines),
}


def bed_state(clumps, floor_forces):
    """The bed's weight, height and energy, and the floor force against them; floor_forces from floor_force()."""
    mass = sum(O.bodies[c].state.mass for c in clumps)
    floor, inertia = floor_forces
    heights = [O.bodies[c].state.pos[2] for c in clumps]
    return {"weight_n": mass * gravity, "floor_force_n": floor, "momentum_rate_n": inertia,
            "floor_force_over_weight": floor / (mass * gravity),
            "momentum_balance_error_over_weight": (floor - mass * gravity - inertia) / (mass * gravity),
            "mean_height_m": statistics.fmean(heights),
            "potential_energy_j": sum(O.bodies[c].state.mass * gravity * O.bodies[c].state.pos[2] for c in clumps),
            "max_speed_m_s": max(O.bodies[c].state.vel.norm() for c in clumps)}


def contact_counts(clumps):
    """Sphere contacts (each counted once; between stones, and with the walls) and touching stone pairs per stone."""
    member_contacts, pairs = 0, set()
    for i in O.interactions:
        if not i.isReal:
            continue
        member_contacts += 1
        b1, b2 = O.bodies[i.id1], O.bodies[i.id2]
        if b1.isClumpMember and b2.isClumpMember:
            pairs.add((min(b1.clumpId, b2.clumpId), max(b1.clumpId, b2.clumpId)))
    return member_contacts / len(clumps), len(pairs) / len(clumps)


def vertical_momentum():
    return sum(O.bodies[c].state.mass * O.bodies[c].state.vel[2] for c in clumps)


def floor_force(floor, steps):
    """Mean upward force of the floor on the stones over `steps` steps [N] (forces persist until the next step), and
    the mean rate of change of the bed's vertical momentum over them [N]: their difference is the weight (nothing else
    pushes vertically: the side walls are frictionless)."""
    start = vertical_momentum()
    total = 0.0
    for _ in range(steps):
        O.step()
        total += -O.forces.f(floor)[2]
    return total / steps, (vertical_momentum() - start) / (steps * O.dt)


# 1. The bed, settled once on the railcosim path (or read from --bed, where an earlier run of the same arguments left
#    it: `railcosim bench clusters` settles one bed for its one- and two-thread runs).
bed_key = {k: getattr(args, k) for k in ("stones", "size", "box", "seed")}
start = time.perf_counter()
if args.bed and os.path.exists(args.bed):
    O.load(args.bed)
    if json.loads(O.tags["cluster_cost_bed"]) != bed_key:
        raise ValueError(f"cluster_cost: the bed in {args.bed} was settled for {O.tags['cluster_cost_bed']}, "
                         f"not {json.dumps(bed_key)}")
    floor = 0  # the first body build_bed appends
    clumps = [b.id for b in O.bodies if b.isClump]
else:
    floor, clumps, smallest = build_bed()
    # The stone's P-wave step, as the beam case takes it for clusters (cases/beam_uniform_load/dem.py): a contact on a
    # member moves the whole stone.
    O.dt = 0.3 * 0.5 * smallest * math.sqrt(density / young)
    # Frictionless deposition (Tran's gravitational packing, yade_engines/clusters/pack_ballast.py) packs the lattice's
    # columns down without jamming, undamped in the fall (Cundall damping would halve gravity), quenched once down;
    # then the stones get their friction and come to rest, first with Cundall damping, then without.
    stone_mat = next(b.mat for b in O.bodies if b.isClumpMember)
    stone_mat.frictionAngle = 0.0
    fall = math.sqrt(2.0 * max(O.bodies[c].state.pos[2] for c in clumps) / gravity)
    for duration, damping, mu in ((fall + 0.05, 0.0, 0.0), (0.05, 0.3, 0.0), (0.05, 0.3, friction),
                                  (0.05, 0.0, friction)):
        if math.atan(mu) != stone_mat.frictionAngle:
            stone_mat.frictionAngle = math.atan(mu)
            O.interactions.clear()  # the contacts' physics take the new friction
        O.engines = railcosim_engines(damping, gravity)
        O.run(int(duration / O.dt), True)
    if args.bed:
        O.tags["cluster_cost_bed"] = json.dumps(bed_key)
        os.makedirs(os.path.dirname(os.path.abspath(args.bed)), exist_ok=True)
        O.save(args.bed)
settle_s = time.perf_counter() - start
members = sum(1 for b in O.bodies if b.isClumpMember)
settled = bed_state(clumps, floor_force(floor, args.sample))
print(f"bed: {len(clumps)} stones, {members} spheres, dt {O.dt:.3e} s, settled in {O.iter} steps "
      f"({settle_s:.0f} s wall): "
      f"mean height {settled['mean_height_m']:.4f} m, floor force / weight {settled['floor_force_over_weight']:.4f}, "
      f"max speed {settled['max_speed_m_s']:.2e} m/s", flush=True)
O.saveTmp("settled")


def timed_run(path):
    """Restores the settled bed, puts the path's materials and engines in place, times it; returns its record."""
    O.loadTmp("settled")
    make_material, make_engines = PATHS[path]
    stone_mat = O.materials.append(make_material(math.atan(friction)))
    wall_mat = O.materials.append(make_material(0.0))
    for b in O.bodies:
        if b.isClump:
            continue
        b.mat = O.materials[wall_mat] if (isinstance(b.shape, Wall) and b.id != floor) else O.materials[stone_mat]
    O.interactions.clear()
    O.engines = make_engines()
    O.run(args.warmup, True)
    O.timingEnabled = True
    for e in O.engines:
        e.execTime = 0
    start, start_cpu = time.perf_counter(), time.process_time()
    O.run(args.steps, True)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    engines_ns = {e.__class__.__name__: e.execTime for e in O.engines}
    O.timingEnabled = False
    per_stone, pairs_per_stone = contact_counts(clumps)
    physics = bed_state(clumps, floor_force(floor, args.sample))
    stone_steps = args.steps * len(clumps)
    return {"path": path, "wall_s": wall, "cpu_s": cpu,
            "us_per_stone_step": 1e6 * wall / stone_steps, "us_per_sphere_step": 1e6 * wall / (args.steps * members),
            "cpu_us_per_stone_step": 1e6 * cpu / stone_steps,
            "cpu_us_per_sphere_step": 1e6 * cpu / (args.steps * members),
            "engines_us_per_stone_step": {k: 1e-3 * v / stone_steps for k, v in engines_ns.items()},
            "sphere_contacts_per_stone": per_stone, "touching_stones_per_stone": pairs_per_stone, **physics}


runs = []
for repeat in range(args.repeats):
    for path in PATHS:
        record = timed_run(path)
        record["repeat"] = repeat
        runs.append(record)
        print(f"  repeat {repeat} {path:<15} {record['us_per_stone_step']:7.2f} us/stone-step "
              f"({record['wall_s']:.1f} s), floor/weight {record['floor_force_over_weight']:.4f} "
              f"(momentum balance {record['momentum_balance_error_over_weight']:.1e}), "
              f"mean height {record['mean_height_m']:.4f} m", flush=True)


def spread(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


# Wall time is what a user waits; CPU time (all threads of the process) leaves out the time the process spends
# descheduled on a loaded machine, so with one thread it is the steadier measure of the work.
summary = {}
stock = [r for r in runs if r["path"] == "stock"]
for path in PATHS:
    mine = [r for r in runs if r["path"] == path]
    summary[path] = {key: spread([r[key] for r in mine])
                     for key in ("us_per_stone_step", "us_per_sphere_step", "cpu_us_per_stone_step",
                                 "cpu_us_per_sphere_step")}
    summary[path].update({
        "ratio_to_stock": spread([a["us_per_stone_step"] / b["us_per_stone_step"] for a, b in zip(mine, stock)]),
        "cpu_ratio_to_stock": spread([a["cpu_us_per_stone_step"] / b["cpu_us_per_stone_step"]
                                      for a, b in zip(mine, stock)]),
        "engines_us_per_stone_step": {k: statistics.median([r["engines_us_per_stone_step"][k] for r in mine])
                                      for k in mine[0]["engines_us_per_stone_step"]},
        "sphere_contacts_per_stone": statistics.median([r["sphere_contacts_per_stone"] for r in mine]),
        "touching_stones_per_stone": statistics.median([r["touching_stones_per_stone"] for r in mine]),
    })

# Physics check: the same bed on every path.
problems = []
for r in runs:
    if abs(r["momentum_balance_error_over_weight"]) > MOMENTUM_TOLERANCE:
        problems.append(f"{r['path']} repeat {r['repeat']}: floor force - weight - momentum rate = "
                        f"{r['momentum_balance_error_over_weight']:.2e} x weight")
    if abs(r["floor_force_over_weight"] - 1.0) > FLOOR_FORCE_TOLERANCE:
        problems.append(f"{r['path']} repeat {r['repeat']}: floor force / weight {r['floor_force_over_weight']:.4f}")
for a, b in zip([r for r in runs if r["path"] == "railcosim"], [r for r in runs if r["path"] == "stock"]):
    if abs(a["mean_height_m"] - b["mean_height_m"]) > HEIGHT_TOLERANCE * args.size:
        problems.append(f"repeat {a['repeat']}: mean height railcosim {a['mean_height_m']:.5f} m, "
                        f"stock {b['mean_height_m']:.5f} m")

load = os.getloadavg()
print(f"\n{len(clumps)} stones ({members} spheres), {args.steps} steps of {O.dt:.3e} s, {threads} thread(s), "
      f"{args.repeats} repeats, load {load[0]:.1f}")

def cell(figure, digits=2):
    return f"{figure['median']:.{digits}f} ({figure['min']:.{digits}f}-{figure['max']:.{digits}f})"


print(f"{'path':<15} {'wall us/stone-step':>21} {'ratio':>17} {'CPU us/stone-step':>21} {'ratio':>17} "
      f"{'us/sphere':>9} {'contacts':>8} | engines [us/stone-step]: loop, integrator, collider")
for path, s in summary.items():
    e = s["engines_us_per_stone_step"]
    integrator = e.get("QuaternionIntegrator", e.get("NewtonIntegrator"))
    print(f"{path:<15} {cell(s['us_per_stone_step']):>21} {cell(s['ratio_to_stock']):>17} "
          f"{cell(s['cpu_us_per_stone_step']):>21} {cell(s['cpu_ratio_to_stock']):>17} "
          f"{s['cpu_us_per_sphere_step']['median']:9.3f} {s['sphere_contacts_per_stone']:8.2f} | "
          f"{e['InteractionLoop']:.2f}, {integrator:.2f}, {e['InsertionSortCollider']:.2f}")
print("physics check:", "PASS" if not problems else "MISMATCH\n  " + "\n  ".join(problems))

if args.json:
    path = os.path.abspath(args.json)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    document = {"benchmark": "cluster_cost", "by_threads": {}}
    if os.path.exists(path):
        with open(path) as f:
            previous = json.load(f)
        if previous.get("benchmark") == "cluster_cost":
            document = previous
    document["by_threads"][str(threads)] = {
        "date": datetime.date.today().isoformat(), "load_average_1_5_15": load, "threads": threads,
        "stones": len(clumps), "spheres": members, "cluster_level": level, "mean_sieve_size_m": args.size,
        "box_m": args.box, "time_step_s": O.dt, "steps": args.steps, "warmup_steps": args.warmup,
        "sample_steps": args.sample,
        "repeats": args.repeats, "settled": settled,
        "materials": {"young_pa": young, "poisson": poisson, "density_kg_m3": density, "friction": friction,
                      "restitution": restitution},
        "physics_check": {"momentum_tolerance": MOMENTUM_TOLERANCE, "floor_force_tolerance": FLOOR_FORCE_TOLERANCE,
                          "height_tolerance_of_size": HEIGHT_TOLERANCE,
                          "problems": problems},
        "summary": summary, "runs": runs}
    with open(path, "w") as f:
        json.dump(document, f, indent=2)
    print("written", path)
if problems:
    sys.exit(1)
