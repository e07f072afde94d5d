"""YADE helper: fills a box with sphere-cluster ballast stones (EN 13450 grading) by gravity deposition; reports porosity.

Run inside YADE (its Python has numpy/scipy), e.g.
    yade -n -x yade_engines/clusters/pack_ballast.py --box 0.2 0.2 0.2 --level coarse --time 0.6
or import it from a YADE script (put yade_engines/clusters on sys.path) and call packBallastBox(...).

Method (Irazábal 2017 §6.2.3 / Tran): stones drawn from the shape library with the grading sampler, placed
without overlap on a loose lattice above the box, then settled under gravity with zero friction (the
compaction then depends only on shape, grading and gravity), and with viscous contact damping plus
numerical damping to dissipate the fall. Porosity = 1 - solid fraction, sampled on a grid in the interior of
the bed (one maximum stone size away from the walls and from the top surface, where the packing is loose).
"""

import math
import os
import sys

import numpy as np


def _clustersFolder():
    # YADE's `-x script.py` runs the script without setting __file__ to it; sys.argv[0] names it then.
    candidates = [os.environ.get("RAILCOSIM_CLUSTERS_DIR", "")]
    if "__file__" in globals():
        candidates.append(os.path.dirname(os.path.abspath(__file__)))
    candidates += [os.path.dirname(os.path.abspath(a)) for a in sys.argv[:1] if a]
    for folder in candidates:
        if folder and os.path.isfile(os.path.join(folder, "ballast_clusters.py")):
            return folder
    raise ImportError("pack_ballast: cannot find ballast_clusters.py next to this script; set RAILCOSIM_CLUSTERS_DIR "
                      "to yade_engines/clusters")


sys.path.insert(0, _clustersFolder())
import ballast_clusters as bc  # noqa: E402


def _yade():
    import yade  # noqa: F401  (only available inside YADE)
    from yade import utils
    return yade, utils


def addClusterStone(stone, centre, material, discretization=30):
    """Appends one stone (a dict from ballast_clusters.sampleBallastStones) as a YADE clump; returns the clump id.

    YADE places the clump at the centroid and principal axes of its own rasterisation of the sphere union
    (`discretization` cells across; measured on the library: 0.2 % mass, 0.5 % inertia error at 30; the
    default 0 would count overlaps several times, up to 7x the mass). Mass and principal moments are then
    replaced by the library values (1e-4 accurate), matched to YADE's axes by size.
    """
    yade, utils = _yade()
    rotation = stone["rotation"]
    members = [utils.sphere(tuple(np.asarray(centre) + rotation @ s[:3]), float(s[3]), material=material)
               for s in stone["spheres"]]
    clumpId, _ = yade.O.bodies.appendClumped(members, discretization=discretization)
    state = yade.O.bodies[clumpId].state
    yadeMoments = np.array([state.inertia[0], state.inertia[1], state.inertia[2]])
    moments = np.empty(3)
    moments[np.argsort(yadeMoments)] = np.sort(stone["principalInertia"])
    state.mass = float(stone["mass"])
    state.inertia = yade.Vector3(*moments)
    return clumpId


def packBallastBox(box=(0.3, 0.3, 0.3), level="fine", seed=1, density=2700.0, youngModulus=1e7,
                   poissonRatio=0.2, restitution=0.2, numericalDamping=0.3, settleTime=1.0, integrator="quaternion",
                   scheme="zhaoVanWachem", timeStepSafety=0.3, library=None, quiet=False):
    """Builds and settles a ballast bed in the box [0, box] (m); returns a dict with the porosity and counts.

    box [m]; density [kg/m^3]; youngModulus [Pa] (packing modulus: lower than real rock for a larger time
    step, settling under self-weight needs no more); restitution [-]; numericalDamping [-] (Cundall);
    settleTime [s] of simulated time; integrator "quaternion" (QuaternionIntegrator, railcosim plugin) or
    "newton" (stock NewtonIntegrator, e.g. in Debian's YADE).
    """
    yade, utils = _yade()
    O = yade.O
    rng = np.random.default_rng(seed)
    library = library or bc.loadShapeLibrary()
    box = np.asarray(box, dtype=float)
    boxVolume = float(np.prod(box))
    # Enough stones for a bed filling the box at ~40 % porosity, plus a little for the loose top.
    stones = bc.sampleBallastStones(library, rng, 0.65 * boxVolume, level=level, density=density)
    maxReach = max(s["enclosingRadius"] for s in stones)

    O.reset()
    stoneMaterial = O.materials.append(yade.FrictMat(young=youngModulus, poisson=poissonRatio, density=density,
                                                     frictionAngle=0.0, label="ballast"))
    wallMaterial = O.materials.append(yade.FrictMat(young=youngModulus, poisson=poissonRatio, density=density,
                                                    frictionAngle=0.0, label="walls"))
    # Random sequential placement of the enclosing spheres in a column over the box footprint: a dense
    # enough cloud to settle quickly, with no initial overlap. The column grows when a stone does not fit.
    reaches = np.array([s["enclosingRadius"] for s in stones])
    order = np.argsort(-reaches)  # largest first: they are the hardest to place
    centres = np.zeros((len(stones), 3))
    height = box[2]
    for count, index in enumerate(order):
        reach = reaches[index]
        for attempt in range(2000):
            if attempt and attempt % 200 == 0:
                height *= 1.1
            candidate = np.array([rng.uniform(reach, box[0] - reach), rng.uniform(reach, box[1] - reach),
                                  rng.uniform(reach, height - reach)])
            if count == 0 or np.all(np.linalg.norm(centres[order[:count]] - candidate, axis=1) >=
                                    reaches[order[:count]] + reach):
                centres[index] = candidate
                break
        else:
            raise RuntimeError("packBallastBox: could not place stone %d of %d (reach %.3g m) in a box %s; use a box "
                               "at least two largest stones wide" % (count, len(stones), reach, box))
    walls = utils.aabbWalls([(0, 0, 0), (box[0], box[1], height + maxReach)], thickness=0.1 * box[0],
                            material=wallMaterial, oversizeFactor=1.2)
    O.bodies.append(walls)
    clumpIds = [addClusterStone(stone, centre, stoneMaterial) for stone, centre in zip(stones, centres)]
    if integrator == "quaternion":
        motion = yade.QuaternionIntegrator(gravity=(0, 0, -9.81), damping=numericalDamping, scheme=scheme)
    elif integrator == "newton":
        motion = yade.NewtonIntegrator(gravity=(0, 0, -9.81), damping=numericalDamping)
    else:
        raise ValueError("packBallastBox: integrator must be 'quaternion' or 'newton', got %r" % integrator)
    O.engines = [
        yade.ForceResetter(),
        yade.InsertionSortCollider([yade.Bo1_Sphere_Aabb(), yade.Bo1_Box_Aabb()]),
        yade.InteractionLoop([yade.Ig2_Sphere_Sphere_ScGeom(), yade.Ig2_Box_Sphere_ScGeom()],
                             [yade.Ip2_FrictMat_FrictMat_MindlinPhys(en=restitution, es=restitution)],
                             [yade.Law2_ScGeom_MindlinPhys_Mindlin()]),
        motion,
    ]
    O.dt = timeStepSafety * utils.PWaveTimeStep()
    steps = int(settleTime / O.dt)
    O.run(steps, True)

    # Porosity on a grid in the interior: one maximum stone size from walls and from the bed surface.
    spheres = np.array([(b.state.pos[0], b.state.pos[1], b.state.pos[2], b.shape.radius)
                        for b in O.bodies if b.isClumpMember])
    surface = np.percentile(spheres[:, 2] + spheres[:, 3], 95.0)
    margin = 2.0 * maxReach
    lower = np.array([margin, margin, margin])
    upper = np.array([box[0] - margin, box[1] - margin, surface - margin])
    porosity = float("nan")
    if np.all(upper > lower):
        from scipy.spatial import cKDTree
        axes = [np.linspace(lower[k], upper[k], 40) for k in range(3)]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        tree = cKDTree(spheres[:, :3])
        solid = np.zeros(len(points), dtype=bool)
        radiusMax = spheres[:, 3].max()
        for i, neighbours in enumerate(tree.query_ball_point(points, radiusMax)):
            if neighbours:
                d = np.linalg.norm(spheres[neighbours, :3] - points[i], axis=1)
                solid[i] = np.any(d <= spheres[neighbours, 3])
        porosity = 1.0 - solid.mean()
    kinetic = sum(0.5 * O.bodies[i].state.mass * O.bodies[i].state.vel.squaredNorm() for i in clumpIds)
    result = {"stones": len(clumpIds), "spheres": len(spheres), "timeStep": O.dt, "steps": steps,
              "bedSurface": float(surface), "porosity": porosity, "kineticEnergy": kinetic,
              "grading": bc.gradingReport([s["sieveSize"] * 1e3 for s in stones], [s["mass"] for s in stones])}
    if not quiet:
        print("packBallastBox: %d stones (%d spheres), dt %.3g s, %d steps, bed surface %.3f m, interior porosity "
              "%.1f %%, residual kinetic energy %.3g J, grading compliant: %s"
              % (result["stones"], result["spheres"], O.dt, steps, surface, 100 * porosity, kinetic,
                 result["grading"]["compliant"]))
    return result


if __name__ == "__main__" and "yade" in sys.modules and os.path.basename(sys.argv[0]) == "pack_ballast.py":
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--box", type=float, nargs=3, default=(0.3, 0.3, 0.3), help="box size [m]")
    parser.add_argument("--level", choices=("coarse", "fine"), default="fine")
    parser.add_argument("--time", type=float, default=1.0, help="settling time [s]")
    parser.add_argument("--integrator", choices=("quaternion", "newton"), default="quaternion")
    parser.add_argument("--seed", type=int, default=1)
    arguments = parser.parse_args(sys.argv[1:])
    packBallastBox(tuple(arguments.box), arguments.level, arguments.seed, settleTime=arguments.time,
                   integrator=arguments.integrator)
