# Cost of coupling the polyhedra DEM to an FE surface: a settled bed of library stones timed on a floor of Facet walls,
# then on the same floor served as a coupled surface by the stand-in FEM (FemCouplingEngine contactModel='polyhedra').
# Run: ./railcosim yade benchmarks/polyhedra_coupling.py PATH/TO/railcosim_dummy_fem [STONES] [STEPS] [SUBCYCLES]
#      (YADE runs one OpenMP thread unless OMP_NUM_THREADS says otherwise)
# Prints one JSON record: seconds per stone-step uncoupled and coupled, and where the coupled run spent its time.
import json
import math
import os
import subprocess
import sys
import time
import uuid

dummy_fem = sys.argv[1]
stones = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
steps = int(sys.argv[3]) if len(sys.argv) > 3 else 2000
subcycles = int(sys.argv[4]) if len(sys.argv) > 4 else 20
side, nodes = 0.6, 13  # the floor: 0.6 m square, 13 x 13 nodes (288 triangles), as facets or as the FE surface
size, dilation, dt = 0.03, 0.003, 2e-5

library = json.load(open(os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters", "shapes", "library.json")))
cores = [[Vector3(*v) * size * 0.8 for v in shape["vertices"]] for shape in library["shapes"]]
mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=math.atan(0.6)))
spacing = 0.045
per_side = int(side / spacing)
stone_ids = []
for k in range(stones):
    layer, cell = divmod(k, per_side * per_side)
    i, j = divmod(cell, per_side)
    centre = (spacing * (i + 0.5), spacing * (j + 0.5), 0.03 + spacing * layer)
    stone_ids.append(O.bodies.append(utils.sphere(centre, 0.02, material=mat)))
    O.bodies[stone_ids[-1]].state.ori = Quaternion(Vector3(1, 2, 3 + k % 5).normalized(), 0.7 * k)
grid = [Vector3(side * i / (nodes - 1), side * j / (nodes - 1), 0) for j in range(nodes) for i in range(nodes)]
floor = []
for j in range(nodes - 1):
    for i in range(nodes - 1):
        a, b, c, d = j * nodes + i, j * nodes + i + 1, (j + 1) * nodes + i + 1, (j + 1) * nodes + i
        floor.append(O.bodies.append(utils.facet((grid[a], grid[b], grid[c]), material=mat)))
        floor.append(O.bodies.append(utils.facet((grid[a], grid[c], grid[d]), material=mat)))
height = 0.06 + spacing * (stones // (per_side * per_side) + 1)
corners = [Vector3(0, 0, 0), Vector3(side, 0, 0), Vector3(side, side, 0), Vector3(0, side, 0)]
for k in range(4):  # side walls, counter-clockwise seen from inside
    a, b = corners[k], corners[(k + 1) % 4]
    top = [Vector3(p[0], p[1], height) for p in (a, b)]
    O.bodies.append(utils.facet((a, top[1], b), material=mat))
    O.bodies.append(utils.facet((a, top[0], top[1]), material=mat))


def engine():
    e = PolyhedraGpuEngine(dilationRadius=dilation, restitution=0.3, backend="cpu", syncInterval=subcycles,
                           neighbourSkin=dilation, rebuildInterval=5, maxNeighbours=32, maxWallNeighbours=16)
    for b in stone_ids:
        e.addStone(b, cores[b % len(cores)])
    return e


# 1. Settle on the facet floor (0.6 s: the top layer falls ~0.3 m), then time the uncoupled bed.
O.engines = [engine()]
O.dt = dt
O.run(subcycles * int(0.6 / dt / subcycles), True)
settled = max(O.bodies[b].state.vel.norm() for b in stone_ids)
start = time.perf_counter()
O.run(steps, True)
uncoupled = (time.perf_counter() - start) / (steps * stones)

# 2. The same bed on the same floor as a coupled surface (stiff, heavy stand-in nodes: it hardly moves, but it moves).
for b in floor:
    O.bodies.erase(b)
endpoint = f"ipc:///tmp/railcosim-bench-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", str(nodes), "--ny", str(nodes), "--spacing",
                        str(side / (nodes - 1)), "--dt", str(dt * subcycles), "--mass", "100", "--stiffness", "1e8",
                        "--scheme", "predictive", "--timeout", "60"])
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], contactModel="polyhedra", scheme="predictive",
                             restitution=0.3, timeout=60)
O.engines = [coupling, engine()]
coupling.connect()
O.run(subcycles, True)  # the first window: initialization
start = time.perf_counter()
O.run(steps, True)
coupled = (time.perf_counter() - start) / (steps * stones)
coupling.finalize()
fem.wait(10)
record = {"stones": stones, "steps": steps, "subcycles": subcycles, "threads": os.environ.get("OMP_NUM_THREADS", "all"),
          "max_speed_before_timing_m_s": settled,
          "uncoupled_s_per_stone_step": uncoupled, "coupled_s_per_stone_step": coupled, "ratio": coupled / uncoupled,
          "polyhedra_time_s": coupling.polyhedraTime, "mapping_time_s": coupling.mappingTime,
          "bridge_time_s": coupling.bridgeTime, "wait_time_s": coupling.waitTime}
print(json.dumps(record), flush=True)
