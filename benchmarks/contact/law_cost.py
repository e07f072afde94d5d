"""Benchmark: cost per contact of Law2_ScGeom_BallastPhys_Ballast against stock Law2_ScGeom_MindlinPhys_Mindlin.

USAGE:   ./railcosim yade benchmarks/contact/law_cost.py [--side 22] [--steps 300] [--json PATH]
OUTPUTS: a table (ns per contact-step of the whole InteractionLoop and of the law alone, ratio to stock
         Hertz-Mindlin); JSON records only with --json (`./railcosim bench contact` passes a path outside
         the tracked tree unless --save asks for benchmarks/results/contact_law_cost.json).
Scene: side^3 spheres (22^3 = 10,648) of radius 5 mm on a simple cubic lattice compressed by 0.2 % of the
diameter, so every interior sphere has 6 contacts from the first step; no gravity and a tiny time step,
so all laws see the same geometry. Timing uses YADE's engine timers; not a test.
"""
import argparse
import json
import os
import sys
import time

parser = argparse.ArgumentParser()
parser.add_argument("--side", type=int, default=22)
parser.add_argument("--steps", type=int, default=300)
parser.add_argument("--json", default=None, help="also write the records to this file (none by default)")
args = parser.parse_args(sys.argv[1:])

radius, young, poisson, density = 0.005, 5e8, 0.25, 2600.0
spacing = 2 * radius * 0.998


def lattice(material):
    for i in range(args.side):
        for j in range(args.side):
            for k in range(args.side):
                O.bodies.append(utils.sphere((i * spacing, j * spacing, k * spacing), radius, material=material))


def run(label, material_factory, ip2, law):
    O.reset()
    material = O.materials.append(material_factory())
    lattice(material)
    loop = InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [ip2], [law], label="loop")
    # A time step far below the contact period: positions barely move, so every law sees the same contacts.
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]), loop,
                 NewtonIntegrator(damping=0, gravity=(0, 0, 0))]
    O.dt = 1e-8
    O.step()  # creates the interactions
    O.timingEnabled = True
    for e in O.engines:
        e.execTime = 0
    start = time.perf_counter()
    for _ in range(args.steps):
        O.step()
    wall = time.perf_counter() - start
    contacts = sum(1 for i in O.interactions if i.isReal)
    per_contact_ns = loop.execTime / (args.steps * contacts)  # execTime is in ns
    record = {"law": label, "spheres": len(O.bodies), "contacts": contacts, "steps": args.steps,
              "interaction_loop_ns_per_contact": per_contact_ns, "wall_s": wall}
    O.timingEnabled = False
    return record


stock = run("Law2_ScGeom_MindlinPhys_Mindlin (stock, no damping)",
            lambda: FrictMat(young=young, poisson=poisson, density=density, frictionAngle=0.5),
            Ip2_FrictMat_FrictMat_MindlinPhys(), Law2_ScGeom_MindlinPhys_Mindlin())
stock_damped = run("Law2_ScGeom_MindlinPhys_Mindlin (stock, en=0.5)",
                   lambda: FrictMat(young=young, poisson=poisson, density=density, frictionAngle=0.5),
                   Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(algo="val", val=0.5),
                                                     es=MatchMaker(algo="val", val=0.5)),
                   Law2_ScGeom_MindlinPhys_Mindlin())
plain = run("Law2_ScGeom_BallastPhys_Ballast (plain Hertz-Mindlin, e=0.5)",
            lambda: BallastMat(young=young, poisson=poisson, density=density, frictionAngle=0.5, restitution=0.5),
            Ip2_BallastMat_BallastMat_BallastPhys(), Law2_ScGeom_BallastPhys_Ballast())
full = run("Law2_ScGeom_BallastPhys_Ballast (Pohrt-Popov plastic + stress-dependent friction + rolling)",
           lambda: BallastMat(young=young, poisson=poisson, density=density, frictionAngle=0.5, restitution=0.5,
                              roughnessFractalDim=2.2, roughnessRms=2e-6, plasticUnloading=True,
                              frictionExponent=-0.1, maxContactStress=5e6, rollingFriction=0.2),
           Ip2_BallastMat_BallastMat_BallastPhys(), Law2_ScGeom_BallastPhys_Ballast())

records = [stock, stock_damped, plain, full]
print(f"{'law':<92} {'contacts':>8} {'ns/contact-step':>16} {'ratio':>7}")
for r in records:
    r["ratio_to_stock_mindlin_damped"] = r["interaction_loop_ns_per_contact"] / stock_damped["interaction_loop_ns_per_contact"]
    print(f"{r['law']:<92} {r['contacts']:>8} {r['interaction_loop_ns_per_contact']:>16.1f} "
          f"{r['ratio_to_stock_mindlin_damped']:>7.2f}")
if args.json:
    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    with open(args.json, "w") as f:
        json.dump({"benchmark": "contact_law_cost", "threads": 1, "records": records}, f, indent=2)
    print("written", args.json)
