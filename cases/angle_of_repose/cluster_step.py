# The time step of the library clusters with the case's contact law (e = 0): one stone of each library shape, at the
# smallest sieve size of the grading (22.4 mm, the stiffest contact for its inertia) and three random orientations,
# hits the floor at the hopper's drop speed (3.7 m/s down, 0.5 m/s along). With e = 0 the impact can only take energy
# away: the largest kinetic energy after the first contact, over the impact energy (kinetic + gravity over 3 cm),
# stays below 1 while the step is stable and grows past it once the step is too large (README, "Time step").
# With --roll instead: each shape (one orientation, 30 mm) is launched along the floor at 0.5 m/s, spinning about the
# horizontal axis across its path; over 0.2 s its kinetic + potential energy must not rise above the start's, and
# the distance it rolls and its final speed are printed (README, "Rolling stones").
# Run: ./railcosim yade cases/angle_of_repose/cluster_step.py LEVEL STEPS_US [YOUNG_PA] [--roll]
#      e.g. ./railcosim yade cases/angle_of_repose/cluster_step.py coarse 1,2,3,4
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"))
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402

rolling = "--roll" in sys.argv
arguments = [a for a in sys.argv[1:] if a != "--roll"]
level = arguments[0]
steps = [1e-6 * float(x) for x in arguments[1].split(",")]
young = float(arguments[2]) if len(arguments) > 2 else 2.4e9
SIZE, DENSITY, FALL, DURATION = 0.0224, 2700.0, 0.03, 0.03  # m, kg/m3, m (allowance for the fall), s
library = ballast_clusters.loadShapeLibrary()


def stone_on_floor(shape, rng, dt, size, height):
    """A scene with the floor and one library stone at `size` [m], its enclosing sphere `height` [m] above the floor;
    returns the stone dict and the clump's state."""
    O.reset()
    mat = O.materials.append(BallastMat(young=young, poisson=0.2, density=DENSITY, restitution=0.0,
                                        frictionAngle=math.atan(0.6)))
    O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=mat))
    cluster = shape["clusters"][level]
    stone = {"rotation": ballast_clusters.randomRotation(rng), "spheres": cluster["spheres"] * size,
             "mass": DENSITY * cluster["volume"] * size ** 3,
             "principalInertia": DENSITY * cluster["principalInertia"] * size ** 5,
             "reach": cluster["enclosingRadius"] * size}
    clump = pack_ballast.addClusterStone(stone, (0, 0, stone["reach"] + height), O.materials[mat])
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                                 [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
                 QuaternionIntegrator(scheme="zhaoVanWachem", damping=0.0, gravity=(0, 0, -9.81))]
    O.dt = dt
    return stone, O.bodies[clump].state


def kinetic_energy(state):
    spin = state.ori.conjugate() * state.angVel  # body axes: the clump's principal axes
    return 0.5 * state.mass * state.vel.squaredNorm() + 0.5 * sum(state.inertia[j] * spin[j] ** 2 for j in range(3))


def impact(shape, rng, dt):
    """Largest kinetic energy after the stone's release over its impact energy."""
    stone, state = stone_on_floor(shape, rng, dt, SIZE, 1e-3)
    state.vel = Vector3(0.5, 0, -3.7)
    supplied = 0.5 * stone["mass"] * (0.5 ** 2 + 3.7 ** 2) + stone["mass"] * 9.81 * FALL
    largest = 0.0
    while O.time < DURATION:
        O.run(100, True)
        energy = kinetic_energy(state)
        largest = max(largest, energy / supplied)
        if not math.isfinite(energy) or largest > 100.0:
            break
    return largest


def roll(shape, rng, dt):
    """Largest kinetic + potential energy after the first 5 ms over the start's, distance and speed after 0.2 s."""
    stone, state = stone_on_floor(shape, rng, dt, 0.03, 1e-3)
    state.vel = Vector3(0.5, 0, 0)
    state.angVel = Vector3(0, 0.5 / (0.6 * stone["reach"]), 0)

    def energy():
        return kinetic_energy(state) + state.mass * 9.81 * state.pos[2]
    start, largest = energy(), 0.0
    while O.time < 0.2:
        O.run(max(1, int(2e-4 / dt)), True)
        if O.time > 5e-3:
            largest = max(largest, energy() / start)
        if not math.isfinite(largest) or largest > 100.0:
            break
    return largest, state.pos[0], state.vel.norm()


if rolling:
    print(f"{level} clusters, 30 mm, E = {young:.3g} Pa, rolling along the floor for 0.2 s")
    for dt in steps:
        rows = [roll(shape, np.random.default_rng(10 * k), dt) for k, shape in enumerate(library["shapes"])]
        print(f"  step {1e6 * dt:.2f} µs: largest energy / start {max(r[0] for r in rows):.3f}, rolled "
              f"{min(r[1] for r in rows):.3f}-{max(r[1] for r in rows):.3f} m, final speed up to "
              f"{max(r[2] for r in rows):.2f} m/s", flush=True)
    sys.exit(0)
print(f"{level} clusters, d = {1e3 * SIZE:.1f} mm, E = {young:.3g} Pa: largest kinetic energy / impact energy")
for dt in steps:
    ratios = [impact(shape, np.random.default_rng(10 * k + trial), dt)
              for k, shape in enumerate(library["shapes"]) for trial in range(3)]
    print(f"  step {1e6 * dt:.2f} µs: max {max(ratios):.3f}, median {np.median(ratios):.3f} over {len(ratios)} impacts",
          flush=True)
