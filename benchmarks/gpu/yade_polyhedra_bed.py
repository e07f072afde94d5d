# Stock YADE Polyhedra (CGAL, volumetric law) on the benchmark's bed at small N, for the cost comparison.
# Usage: yade -n -x benchmarks/gpu/yade_polyhedra_bed.py [side] [layers] [packing_steps] [timed_steps]
# Same stones as benchmarks/gpu/PolyhedraBench.cpp (dodecahedra scaled by 4 aspect sets, random
# orientations, 0.066 m lattice, packed under 10 g), but YADE's own contact law; prints one JSON record.
import json, math, random, sys, time
from yade import polyhedra_utils

side = int(sys.argv[1]) if len(sys.argv) > 1 else 6
layers = int(sys.argv[2]) if len(sys.argv) > 2 else 6
packing = int(sys.argv[3]) if len(sys.argv) > 3 else 1500
timed = int(sys.argv[4]) if len(sys.argv) > 4 else 100

phi = (1 + 5 ** 0.5) / 2
unit = [(sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
for s1 in (-1, 1):
    for s2 in (-1, 1):
        unit += [(0, s1 / phi, s2 * phi), (s1 / phi, s2 * phi, 0), (s1 * phi, 0, s2 / phi)]
aspects = [(0.030, 0.025, 0.020), (0.026, 0.028, 0.022), (0.028, 0.022, 0.024), (0.024, 0.027, 0.026)]

mat = PolyhedraMat(density=2600, young=1e9, poisson=0.25, frictionAngle=math.atan(0.6))
O.materials.append(mat)
random.seed(2026)
spacing = 0.066
for iz in range(layers):
    for iy in range(side):
        for ix in range(side):
            a, b, c = random.choice(aspects)
            vertices = [Vector3(x * a, y * b, z * c) / 3 ** 0.5 for (x, y, z) in unit]
            body = polyhedra_utils.polyhedra(mat, v=vertices)
            body.state.pos = ((ix + 0.5) * spacing, (iy + 0.5) * spacing, (iz + 0.5) * spacing)
            q = [random.gauss(0, 1) for _ in range(4)]
            n = math.sqrt(sum(x * x for x in q))
            body.state.ori = Quaternion(q[0] / n, q[1] / n, q[2] / n, q[3] / n)
            O.bodies.append(body)
O.bodies.append(utils.wall(0, axis=2, sense=1, material=mat))
for axis, position in ((0, 0), (0, side * spacing), (1, 0), (1, side * spacing)):
    O.bodies.append(utils.wall(position, axis=axis, material=mat))

newton = NewtonIntegrator(gravity=(0, 0, -98.1), damping=0.0)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Polyhedra_Aabb(), Bo1_Wall_Aabb()], verletDist=0.003),
             InteractionLoop([Ig2_Polyhedra_Polyhedra_PolyhedraGeom(), Ig2_Wall_Polyhedra_PolyhedraGeom()],
                             [Ip2_PolyhedraMat_PolyhedraMat_PolyhedraPhys()],
                             [Law2_PolyhedraGeom_PolyhedraPhys_Volumetric()]),
             newton]
O.dt = 5e-5
O.run(packing, True)
newton.gravity = (0, 0, -9.81)
O.dt = 1e-5
stones = side * side * layers
start = time.time()
O.run(timed, True)
wall = time.time() - start
contacts = sum(1 for i in O.interactions if i.isReal)
print(json.dumps({"device": "stock YADE Polyhedra (CGAL), %d thread(s)" % O.numThreads, "backend": "yade-polyhedra",
                  "n_particles": stones, "vertices_per_stone": 20, "steps": timed, "wall_s": wall,
                  "particle_steps_per_s": stones * timed / wall, "contacts_per_s": contacts * timed / wall,
                  "contacts_per_particle": contacts / stones, "fraction_of_bandwidth_bound": None,
                  "prepare_steps": packing}))
