# Does a single library stone stay where it lies? Each of the 8 library stones, in 3 random orientations, 30 mm, is
# dropped 1 mm onto a floor (E 2.4 GPa, μ 0.6, the case's ballast) and left for 0.4 s; then gravity is tilted by 5°,
# 10° and 20° (an incline) for 0.5 s. Printed per stone: its speed after the 0.4 s (at rest or still moving) and how
# far it went on each incline. A stone with a face or three points on the floor stays below the friction angle
# (atan 0.6 = 31°) unless it tips; a body resting on one round point rocks and rolls (README, "Why the clusters do not
# pile").
# Two models of the same stones:
#   clusters (YADE, the case's contact law with e = 0 and the Zhao–van Wachem integrator, 2 µs):
#       ./railcosim yade cases/angle_of_repose/incline_test.py coarse|fine|angular
#   dilated polyhedra (the polyhedra library through its driver, without YADE; r_d a fraction of the size):
#       RAILCOSIM_ROOT=$PWD /usr/bin/python3 cases/angle_of_repose/incline_test.py polyhedra [0.03]
# and, without any dynamics, the static oracle of the stones' hulls: for each face the centroid stands over, the
# smallest tilt that carries the centroid's vertical over an edge (atan(distance to the nearest edge / height)):
#       RAILCOSIM_ROOT=$PWD /usr/bin/python3 cases/angle_of_repose/incline_test.py tipping
import math
import os
import sys

import numpy as np

ROOT = os.environ.get("RAILCOSIM_ROOT", os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "yade_engines", "clusters"))
import ballast_clusters  # noqa: E402

SIZE, DENSITY, YOUNG, FRICTION = 0.03, 2700.0, 2.4e9, 0.6
SETTLE, TILTED, ANGLES = 0.4, 0.5, (5, 10, 20)
library = ballast_clusters.loadShapeLibrary()
model = sys.argv[1] if len(sys.argv) > 1 else "coarse"
if model not in ("coarse", "fine", "angular", "polyhedra", "tipping"):
    sys.exit(f"incline_test.py: the model is coarse, fine, angular, polyhedra or tipping, not {model!r}")
relative_dilation = 0.03
if model == "polyhedra" and len(sys.argv) > 2:
    try:
        relative_dilation = float(sys.argv[2])
    except ValueError:
        relative_dilation = float("nan")
    if not 0 < relative_dilation < 0.5:
        sys.exit(f"incline_test.py: r_d is a fraction of the size, 0 < r_d < 0.5, not {sys.argv[2]!r}")


def tilted_gravity(degrees):
    t = math.radians(degrees)
    return (9.81 * math.sin(t), 0.0, -9.81 * math.cos(t))


def orientation(k, trial):
    return ballast_clusters.randomRotation(np.random.default_rng(100 * k + trial))


def cluster_trial(k, trial):
    """Speed after settling and displacement [m] on each incline of library stone k as a cluster (YADE)."""
    import pack_ballast
    cluster = library["shapes"][k]["clusters"][model]
    stone = {"rotation": orientation(k, trial), "spheres": cluster["spheres"] * SIZE,
             "mass": DENSITY * cluster["volume"] * SIZE ** 3,
             "principalInertia": DENSITY * cluster["principalInertia"] * SIZE ** 5,
             "reach": cluster["enclosingRadius"] * SIZE}
    moved = []
    for degrees in ANGLES:  # the same settling each time, then the incline
        O.reset()
        mat = O.materials.append(BallastMat(young=YOUNG, poisson=0.2, density=DENSITY, restitution=0.0,
                                            frictionAngle=math.atan(FRICTION)))
        O.bodies.append(utils.wall(position=0.0, axis=2, sense=1, material=mat))
        clump = pack_ballast.addClusterStone(stone, (0, 0, stone["reach"] + 1e-3), O.materials[mat])
        integrator = QuaternionIntegrator(scheme="zhaoVanWachem", damping=0.0, gravity=(0, 0, -9.81))
        O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
                     InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                                     [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
                     integrator]
        O.dt = 2e-6
        state = O.bodies[clump].state
        O.run(int(SETTLE / O.dt), True)
        speed, start = state.vel.norm(), Vector3(state.pos)
        integrator.gravity = tilted_gravity(degrees)
        O.run(int(TILTED / O.dt), True)
        moved.append((state.pos - start).norm())
    return speed, moved


def polyhedra_trial(k, trial, relative_dilation):
    """The same for library stone k as a dilated polyhedron (its hull shrunk by r_d, so that the size stays)."""
    sys.path.insert(0, os.path.join(ROOT, "python"))
    from railcosim.polyhedra_driver import PolyhedraBed
    material = (YOUNG, 0.2, 0.2, FRICTION)  # e = 0.2: the driver's law needs e > 0
    floor = np.array([[[-5, -5, 0], [5, -5, 0], [5, 5, 0]], [[-5, -5, 0], [5, 5, 0], [-5, 5, 0]]], float)
    dilation = relative_dilation * SIZE
    vertices = (np.asarray(library["shapes"][k]["vertices"]) * SIZE * (1 - relative_dilation)) @ orientation(k, trial).T

    def run(gravity, pose, duration):
        # a 2-mm skin: a stone rolling at 1 m/s moves less than its half between two list rebuilds
        bed = PolyhedraBed(time_step=1e-6, stone_material=material, gravity=gravity, neighbour_skin=0.002,
                           backend="cpu")
        bed.add_stone(vertices, dilation, DENSITY, *pose)
        bed.set_walls(floor, [0, 0], [material])
        bed.initialize()
        bed.dt = 0.2 * bed.critical_time_step(impact_velocity=0.5)
        bed.step(int(duration / bed.dt))
        p, q, v, _, _ = bed.states()
        return (p[0], q[0]), np.linalg.norm(v[0])

    rest, speed = run((0, 0, -9.81), ((0, 0, dilation + 1e-3 - vertices[:, 2].min()), (1, 0, 0, 0)), SETTLE)
    return speed, [np.linalg.norm(run(tilted_gravity(d), rest, TILTED)[0][0] - rest[0]) for d in ANGLES]


def tipping_angles(vertices, triangles):
    """Smallest tipping angles [deg] of the faces a convex hull can rest on (its solid centroid projects into them)."""
    v, t = np.asarray(vertices, float), np.asarray(triangles, int)
    signed = np.einsum("ij,ij->i", v[t[:, 0]], np.cross(v[t[:, 1]], v[t[:, 2]]))  # 6 × tetrahedron volumes
    centroid = (signed[:, None] * (v[t[:, 0]] + v[t[:, 1]] + v[t[:, 2]]) / 4).sum(axis=0) / signed.sum()
    faces = {}
    for tri in t:  # coplanar triangles make one face
        normal = np.cross(v[tri[1]] - v[tri[0]], v[tri[2]] - v[tri[0]])
        normal /= np.linalg.norm(normal)
        normal = normal if np.dot(normal, v[tri[0]] - centroid) > 0 else -normal
        faces.setdefault(tuple(np.round(normal, 6)), set()).update(tri.tolist())
    angles = []
    for normal, corners in faces.items():
        n = np.array(normal)
        points = v[sorted(corners)] - centroid
        height = np.dot(points[0], n)
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        polygon = np.stack([points @ u, points @ w], axis=1)  # the centroid projects to the origin
        middle = polygon.mean(axis=0)
        polygon = polygon[np.argsort(np.arctan2(*(polygon - middle).T[::-1]))]
        edges = np.roll(polygon, -1, axis=0) - polygon
        inward = np.stack([-edges[:, 1], edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1)[:, None]
        inward *= np.sign(np.einsum("ij,ij->i", middle - polygon, inward))[:, None]
        distance = np.einsum("ij,ij->i", -polygon, inward)  # > 0 inside
        if distance.min() > 0:
            angles.append(math.degrees(math.atan(distance.min() / height)))
    return sorted(angles)


if model == "tipping":
    for k, shape in enumerate(library["shapes"]):
        angles = tipping_angles(shape["vertices"], shape["triangles"])
        print(f"stone {k} ({shape['name']}): {len(angles)} faces to rest on; smallest tipping angles "
              + ", ".join(f"{a:.0f}°" for a in angles[:6]), flush=True)
    sys.exit(0)

label = (f"{model} clusters" if model != "polyhedra"
         else f"polyhedra, r_d = {100 * relative_dilation:g} % of the size")
print(f"{label}: speed after {SETTLE} s on the floor; displacement in {TILTED} s on inclines of "
      + ", ".join(f"{a}°" for a in ANGLES))
moving, rolled = 0, [0] * len(ANGLES)
for k in range(len(library["shapes"])):
    for trial in range(3):
        speed, moved = polyhedra_trial(k, trial, relative_dilation) if model == "polyhedra" else cluster_trial(k, trial)
        moving += speed > 0.01
        rolled = [r + (m > 0.02) for r, m in zip(rolled, moved)]
        print(f"  stone {k} ({library['shapes'][k]['name']}), orientation {trial}: {speed:.1e} m/s; "
              + ", ".join(f"{1e3 * m:.1f} mm" for m in moved), flush=True)
count = 3 * len(library["shapes"])
print(f"{label}: {moving} of {count} still faster than 0.01 m/s after {SETTLE} s; moved more than 20 mm: "
      + ", ".join(f"{r} of {count} at {a}°" for r, a in zip(rolled, ANGLES)), flush=True)
