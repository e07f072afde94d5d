# YADE check of PolyhedraGpuEngine: stones registered from a script, advanced in batches, synced back.
# Run: ./railcosim yade yade_engines/checks/polyhedra_gpu_engine.py   (a few seconds; exit 0 when all pass)
# Oracles: free fall z = z0 - g t^2/2 (velocity Verlet is exact under constant gravity); a dilated cube at
# rest on a floor of facets sits at half-edge + r_d above it, less the Hertz overlap under its weight.
import math
import sys

failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message, flush=True)
    if not condition:
        failures.append(message)


half, dilation = 0.01, 0.002
cube = [Vector3(sx * half, sy * half, sz * half) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
g = 9.81


def scene(with_floor):
    O.reset()
    mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=0.5))
    if with_floor:
        corners = [Vector3(-0.2, -0.2, 0), Vector3(0.2, -0.2, 0), Vector3(0.2, 0.2, 0), Vector3(-0.2, 0.2, 0)]
        O.bodies.append(utils.facet((corners[0], corners[1], corners[2]), material=mat))
        O.bodies.append(utils.facet((corners[0], corners[2], corners[3]), material=mat))
    stone = O.bodies.append(utils.sphere((0, 0, 0.1), math.sqrt(3) * half + dilation, material=mat))
    engine = PolyhedraGpuEngine(syncInterval=50, dilationRadius=dilation, restitution=0.3, backend="cpu",
                                gravity=(0, 0, -g), label="poly")
    engine.addStone(stone, cube)
    O.engines = [engine]
    O.dt = 1e-5
    return engine, stone


# 1. Free fall: 2000 steps = 40 batches; the YADE body follows the exact parabola.
engine, stone = scene(False)
O.run(2000, True)
t = O.time
z = O.bodies[stone].state.pos[2]
check(abs(O.time - 2000 * 1e-5) < 1e-12, f"scene time {O.time} s after 2000 steps")
check(abs(z - (0.1 - 0.5 * g * t * t)) < 1e-9, f"free fall: z = {z:.9f} m, exact {0.1 - 0.5 * g * t * t:.9f} m")
check(abs(O.bodies[stone].state.vel[2] + g * t) < 1e-9, f"free fall: v = {O.bodies[stone].state.vel[2]:.6f} m/s")
check(engine.stones == 1 and engine.shapes == 1 and engine.activeBackend == "cpu", f"1 stone, 1 shape on {engine.activeBackend}")

# 2. Rest on a floor of two facets: height = half-edge + r_d - Hertz overlap (< 0.1 mm here).
engine, stone = scene(True)
O.bodies[stone].state.pos = (0.0, 0.0, half + dilation + 0.002)
O.run(60000, True)
state = O.bodies[stone].state
check(state.vel.norm() < 1e-3, f"settled: |v| = {state.vel.norm():.2e} m/s")
check(abs(state.pos[2] - (half + dilation)) < 1e-4, f"rest height {state.pos[2]:.6f} m, expected {half + dilation:.6f} m - overlap")
check(engine.meanContacts >= 1, f"mean contacts {engine.meanContacts}")

# 3. A bed of 27 library stones (8 shapes, 35 mm sieve size, no initial contact) dropped into a box of facets comes to rest in it.
import json
import os
library = json.load(open(os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters", "shapes", "library.json")))
cores = [[Vector3(*v) * 0.035 for v in shape["vertices"]] for shape in library["shapes"]]
O.reset()
mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=0.6))
box = 0.2
floor = [Vector3(0, 0, 0), Vector3(box, 0, 0), Vector3(box, box, 0), Vector3(0, box, 0)]
top = [c + Vector3(0, 0, 0.3) for c in floor]
for a, b, c in ((0, 1, 2), (0, 2, 3)):
    O.bodies.append(utils.facet((floor[a], floor[b], floor[c]), material=mat))
for k in range(4):  # side walls, two facets each, normals inwards
    a, b = k, (k + 1) % 4
    O.bodies.append(utils.facet((floor[a], top[b], floor[b]), material=mat))
    O.bodies.append(utils.facet((floor[a], top[a], top[b]), material=mat))
engine = PolyhedraGpuEngine(syncInterval=100, dilationRadius=0.002, restitution=0.2, backend="cpu", label="bed")
stones = []
for i in range(3):
    for j in range(3):
        for k in range(3):
            centre = (0.035 + 0.065 * i, 0.035 + 0.065 * j, 0.04 + 0.065 * k)
            b = O.bodies.append(utils.sphere(centre, 0.03, material=mat))
            O.bodies[b].state.ori = Quaternion(Vector3(1, 2, 3 + i + j + k).normalized(), 0.7 * (i + 2 * j + 3 * k))
            engine.addStone(b, cores[(i + 3 * j + 9 * k) % len(cores)])
            stones.append(b)
O.engines = [engine]
O.dt = 2e-5
O.run(80000, True)
positions = [O.bodies[b].state.pos for b in stones]
speeds = [O.bodies[b].state.vel.norm() for b in stones]
check(engine.shapes == len(cores), f"{engine.stones} stones share {engine.shapes} shape templates")
check(all(0 < p[0] < box and 0 < p[1] < box and 0 < p[2] < 0.15 for p in positions),
      "every stone rests inside the box, above the floor")
check(max(speeds) < 5e-3, f"bed at rest after {O.time:.2f} s: max |v| = {max(speeds):.2e} m/s")

# 5. Per-stone dilation, wall force, frictionless walls, a moving wall.
# A cube with its own r_d = 5 mm rests at half-edge + 5 mm; the floor carries its weight (wallForce); on a
# frictionless floor (a facet material without friction) it slides at constant speed; a ceiling moved down by setWallVelocity
# travels v t exactly and pushes the cube down with it.
def floor_scene(friction, with_ceiling=False):
    O.reset()
    mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=0.5))
    floor_mat = mat if friction < 0 else O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600,
                                                                       frictionAngle=math.atan(friction)))
    corners = [Vector3(-1, -1, 0), Vector3(1, -1, 0), Vector3(1, 1, 0), Vector3(-1, 1, 0)]
    floor = [O.bodies.append(utils.facet((corners[0], corners[1], corners[2]), material=floor_mat)),
             O.bodies.append(utils.facet((corners[0], corners[2], corners[3]), material=floor_mat))]
    ceiling = []
    if with_ceiling:
        top = [c + Vector3(0, 0, 0.05) for c in corners]
        ceiling = [O.bodies.append(utils.facet((top[0], top[2], top[1]), material=mat)),
                   O.bodies.append(utils.facet((top[0], top[3], top[2]), material=mat))]
    stone = O.bodies.append(utils.sphere((0, 0, half + 0.005), math.sqrt(3) * half + 0.005, material=mat))
    engine = PolyhedraGpuEngine(syncInterval=50, dilationRadius=dilation, restitution=0.3, backend="cpu",
                                gravity=(0, 0, -g))
    engine.addStone(stone, cube, dilationRadius=0.005)
    O.engines = [engine]
    O.dt = 1e-5
    return engine, stone, floor, ceiling


engine, stone, floor, _ = floor_scene(-1)
O.run(30000, True)
# The stone's mass is that of the dilated cube (Steiner: a^3 + 6 a^2 r + 3 pi a r^2 + 4/3 pi r^3), not the YADE sphere's.
a, r = 2 * half, 0.005
weight = 2600 * (a ** 3 + 6 * a * a * r + 3 * math.pi * a * r * r + 4 / 3 * math.pi * r ** 3) * g
check(abs(O.bodies[stone].state.pos[2] - (half + 0.005)) < 1e-4,
      f"own dilation: rest height {O.bodies[stone].state.pos[2]:.6f} m, expected {half + 0.005:.6f} m - overlap")
check(abs(engine.wallForce(floor)[2] + weight) < 1e-3 * weight,
      f"wallForce on the floor {engine.wallForce(floor)[2]:.5f} N, weight {weight:.5f} N")
engine, stone, floor, _ = floor_scene(0.0)
O.bodies[stone].state.vel = (0.1, 0, 0)
O.bodies[stone].state.pos = (0, 0, half + 0.005 - 1e-6)
O.run(10000, True)
check(abs(O.bodies[stone].state.vel[0] - 0.1) < 1e-6, f"frictionless floor: sliding speed {O.bodies[stone].state.vel[0]:.7f} m/s")
engine, stone, floor, ceiling = floor_scene(-1, with_ceiling=True)
O.run(20000, True)
engine.setWallVelocity(ceiling, (0, 0, -0.05))
start = O.bodies[ceiling[0]].state.pos[2]
O.run(5000, True)  # 0.05 s: the ceiling comes down 2.5 mm, onto the cube (gap 50 - 30 mm at rest)
engine.setWallVelocity(ceiling, (0, 0, 0))
moved = start - O.bodies[ceiling[0]].state.pos[2]
check(abs(moved - 0.0025) < 1e-12, f"moving wall travelled {moved * 1e3:.6f} mm in 0.05 s at 50 mm/s")
O.run(20000, True)
check(abs(engine.wallForce(ceiling)[2]) < 1e-12 and O.bodies[stone].state.pos[2] < half + 0.006,
      "the stone is free of the ceiling, which stopped 17.5 mm above it")
engine.setWallVelocity(ceiling, (0, 0, -0.5))
O.run(4000, True)  # 20 mm down: the ceiling now presses the cube into the floor
engine.setWallVelocity(ceiling, (0, 0, 0))
O.run(20000, True)
squeeze = engine.wallForce(ceiling)[2]
check(squeeze > 100 * weight and abs(engine.wallForce(floor)[2] + squeeze + weight) < 1e-3 * weight,
      f"pressed between two walls: ceiling {squeeze:.1f} N up, floor {engine.wallForce(floor)[2]:.1f} N (balance with the weight)")

# 6. Critical time step: the Hertz contact step of the kernels, smaller for a harder contact (8x the force:
# half the squared step), the smaller of force and impact when both are given, and above the checks' 1e-5 s.
engine, stone, floor, _ = floor_scene(-1)
at_force, at_8_force = engine.criticalTimeStep(normalForce=10.0), engine.criticalTimeStep(normalForce=80.0)
at_speed = engine.criticalTimeStep(impactVelocity=1.0)
check(abs((at_8_force / at_force) ** 2 - 0.5) < 1e-9, f"critical step {at_force:.3e} s at 10 N, {at_8_force:.3e} s at 80 N")
check(engine.criticalTimeStep(10.0, 1.0) == min(at_force, at_speed) and at_speed > 1e-5,
      f"critical step at 1 m/s impact {at_speed:.3e} s; both: the smaller")

# 4. Bad input is refused with a message naming the problem.
for action, needle in ((lambda: PolyhedraGpuEngine().addStone(12345, cube), "no body"),
                       (lambda: PolyhedraGpuEngine().addStone(0, cube[:3]), "4 vertices")):
    try:
        action()
        check(False, f"should refuse ({needle})")
    except Exception as error:
        check(needle in str(error), f"refused: {error}")
engine, stone = scene(False)
O.engines = [engine, NewtonIntegrator()]
try:
    O.step()
    check(False, "a NewtonIntegrator beside the engine should be refused")
except Exception as error:
    check("NewtonIntegrator" in str(error), f"refused: {str(error)[:90]}")

print("polyhedra_gpu_engine:", "FAILED" if failures else "passed")
sys.exit(1 if failures else 0)
