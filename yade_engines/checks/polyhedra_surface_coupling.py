# YADE check: polyhedral stones on an FE surface served by the stand-in FEM (FemCouplingEngine contactModel='polyhedra').
# 1. Rest: a library stone on the coupled surface and a second one on a fixed Facet floor beside it. Oracles: the
#    lumped nodal forces add up to the first stone's weight m g (the second's does not reach the surface) and their
#    centroid lies under its centre of mass (moment balance at rest); the second stone's facet contacts carry m g;
#    the engines' Python accessors (contacts, stoneForces) report the same balance.
# 2. Impact: a dilated point-like core (a sphere of radius r_d) thrown at the surface without gravity. Oracles: the
#    stone's momentum change equals minus the impulse the FEM received, sum over the windows of the sent nodal forces
#    times the window (momentum conservation across the interface; with the implicit scheme this also shows that a
#    repeated window's discarded pass left no trace in the stones), and the rebound speed ratio is the contact law's
#    restitution (kernels: Thornton's damping ratio for e, the same e on both materials).
# With the implicit scheme also: windows repeated, every window of the smooth impact converged, O.time = O.iter O.dt
# after the rollbacks.
# Run: ./railcosim yade yade_engines/checks/polyhedra_surface_coupling.py PATH/TO/railcosim_dummy_fem [SCHEME]
import json
import math
import os
import subprocess
import sys
import uuid

from railcosim.dem import run_steps

dummy_fem = sys.argv[1]
scheme = sys.argv[2] if len(sys.argv) > 2 else "justInTime"
failures = []


def check(condition, message):
    print(("ok:   " if condition else "FAIL: ") + message, flush=True)
    if not condition:
        failures.append(message)


def start_fem(nodes_per_side, spacing, dt, mass, stiffness):
    endpoint = f"ipc:///tmp/railcosim-check-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
    fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", str(nodes_per_side), "--ny", str(nodes_per_side),
                            "--spacing", str(spacing), "--dt", str(dt), "--mass", str(mass), "--stiffness", str(stiffness),
                            "--timeout", "30", "--scheme", scheme])
    return fem, endpoint


def implicit_checks(coupling, smooth):
    """`smooth`: the window map is smooth in the surface position, so every window must converge. An angular stone
    rocking on its vertices is not: its contact point jumps between vertices, and in a few % of the windows the
    iteration stalls at about the tolerance (measured: residuals 1.3x the limit); those are counted, not refused."""
    if scheme != "implicit":
        return
    if smooth:
        check(coupling.unconvergedWindows == 0, f"every window converged ({coupling.unconvergedWindows} did not)")
    else:
        print(f"note: {coupling.unconvergedWindows} of {coupling.window} windows accepted unconverged (rocking stone)")
    check(coupling.window < coupling.implicitPasses, f"{coupling.implicitPasses} passes over {coupling.window} windows")
    # Each repeated window winds O.iter and O.time back together; rounding of the summed dt is all that may differ.
    check(abs(O.time - O.iter * O.dt) <= 1e-9 * O.time, f"O.time {O.time:.9f} s = O.iter x O.dt {O.iter * O.dt:.9f} s")


g = 9.81

# ---------------------------------------------------------------------------------------------------------------
# 1. Rest. The surface: 3 x 3 nodes 0.1 m apart (8 triangles on [0, 0.2]^2), each a spring of 2e5 N/m under 0.05 kg.
# ---------------------------------------------------------------------------------------------------------------
fem, endpoint = start_fem(3, 0.1, 2e-4, 0.05, 2.0e5)
library = json.load(open(os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters", "shapes", "library.json")))
core = [Vector3(*v) * 0.035 for v in library["shapes"][0]["vertices"]]  # blocky_a at 35 mm sieve size
mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=math.atan(0.6), label="stone"))
beside = [Vector3(0.3, 0, 0), Vector3(0.5, 0, 0), Vector3(0.5, 0.2, 0), Vector3(0.3, 0.2, 0)]
floor_ids = [O.bodies.append(utils.facet((beside[a], beside[b], beside[c]), material=mat)) for a, b, c in ((0, 1, 2), (0, 2, 3))]
on_surface = O.bodies.append(utils.sphere((0.13, 0.08, 0.022), 0.03, material=mat))
on_facets = O.bodies.append(utils.sphere((0.4, 0.1, 0.022), 0.03, material=mat))
poly = PolyhedraGpuEngine(dilationRadius=0.002, restitution=0.3, backend="cpu", gravity=(0, 0, -g), label="poly")
for b in (on_surface, on_facets):
    poly.addStone(b, core)
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], timeout=30, contactModel="polyhedra",
                             scheme=scheme, restitution=0.3, implicitTolerance=1e-3, label="coupling")
# The polyhedra engine first: initializing it connects the coupling engine, whose surface joins its walls.
O.engines = [poly, coupling]
O.dt = 2e-5
O.step()
check(coupling.connected and coupling.subcycles == 10, f"connected, {coupling.subcycles} DEM steps per window")
check(poly.wallTriangles == 2 + 8, f"{poly.wallTriangles} wall triangles: 2 facets + 8 of the surface")
check(len(coupling.facetIds) == 0, "no facet bodies inserted for the surface")
O.run(10 * 2000 - 1, True)  # 0.4 s: both stones land and come to rest
sums = {"force": Vector3.Zero, "mx": 0.0, "my": 0.0, "n": 0, "facet": 0.0, "stone": Vector3.Zero}
for _ in range(300):
    run_steps(10)
    forces, positions = coupling.nodalForces, coupling.nodePositions
    sums["force"] += sum(forces, Vector3.Zero)
    sums["mx"] += sum(f[2] * x[0] for f, x in zip(forces, positions))
    sums["my"] += sum(f[2] * x[1] for f, x in zip(forces, positions))
    sums["facet"] += sum((c["force"][2] for c in poly.contacts() if c["id1"] == on_facets), 0.0)
    sums["stone"] += poly.stoneForces()[on_facets]
    sums["n"] += 1
n = sums["n"]
weight = O.bodies[on_surface].state.mass * g
mean = sums["force"] / n
# The stand-in's springs are undamped: the surface keeps vibrating a little about its rest state; over 300 windows
# (20 periods of the spring-mass nodes) the mean is within 1 % (lumping and averaging themselves are exact).
check(abs(mean[2] + weight) < 0.01 * weight, f"mean nodal force {mean[2]:.5f} N = -m g {-weight:.5f} N (one stone)")
check(abs(mean[0]) < 0.01 * weight and abs(mean[1]) < 0.01 * weight, f"no net horizontal force ({mean[0]:.2e}, {mean[1]:.2e}) N")
centroid = (sums["mx"] / n / mean[2], sums["my"] / n / mean[2])
com = O.bodies[on_surface].state.pos  # the library stones are stored with their centroid at the origin
# At rest the resultant of the contact forces passes through the centre of mass; 1 mm covers the sway of the stone on
# the vibrating springs (3 % of its size).
check(abs(centroid[0] - com[0]) < 1e-3 and abs(centroid[1] - com[1]) < 1e-3,
      f"nodal force centroid ({centroid[0]:.4f}, {centroid[1]:.4f}) under the stone ({com[0]:.4f}, {com[1]:.4f})")
check(O.bodies[on_surface].state.vel.norm() < 1e-3 and O.bodies[on_facets].state.vel.norm() < 1e-3,
      f"both stones at rest (|v| {O.bodies[on_surface].state.vel.norm():.1e}, {O.bodies[on_facets].state.vel.norm():.1e} m/s)")
# The Python accessors: the facet stone's contacts are with the two facets and carry its weight; the surface stone's
# with surface triangles. A stone resting on a few vertices rocks a little (its instantaneous contact forces swing by a
# few % of m g); their mean over the 300 windows is within 1 %, as above.
contacts = poly.contacts()
facet_load = sums["facet"] / n
facet_weight = O.bodies[on_facets].state.mass * g
check(all(c["id2"] == -1 and c["facet"] in floor_ids and c["surfaceTriangle"] == -1 for c in contacts if c["id1"] == on_facets)
      and any(c["id1"] == on_facets for c in contacts), "the facet stone touches only the facets")
check(all(c["facet"] == -1 and 0 <= c["surfaceTriangle"] < 8 for c in contacts if c["id1"] == on_surface)
      and any(c["id1"] == on_surface for c in contacts), "the surface stone touches only surface triangles")
check(abs(facet_load + facet_weight) < 0.01 * facet_weight,
      f"facet contacts carry {-facet_load:.5f} N, m g = {facet_weight:.5f} N")
stone_force = sums["stone"] / n
check((stone_force - Vector3(0, 0, facet_weight)).norm() < 0.01 * facet_weight,
      f"stoneForces()[facet stone] = {stone_force} N balances m g")
# run_steps(10) ended in the iteration where the next window was stepped; its forces are sent in the next iteration.
window_force = poly.surfaceForce
O.run(1, True)
check(window_force[2] < 0 and (window_force - coupling.totalForce).norm() < 1e-12 * weight,
      f"surfaceForce {window_force[2]:.6f} N = the lumped total sent for that window {coupling.totalForce[2]:.6f} N")
implicit_checks(coupling, smooth=False)
coupling.finalize()
fem.wait(10)
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")

# ---------------------------------------------------------------------------------------------------------------
# 2. Impact without gravity: a sphere of radius 10 mm (a 2 µm tetrahedron dilated by 10 mm, one vertex straight
#    down, so that the contact point lies under the centre) at 0.5 m/s. The surface nodes are heavy and stiff (1 t,
#    1e9 N/m): they take a negligible share of the energy, so the rebound ratio is the law's restitution.
# ---------------------------------------------------------------------------------------------------------------
O.reset()
fem, endpoint = start_fem(3, 0.1, 1e-4, 1e3, 1e9)
e = 0.5
a = 1e-6
tetra = [Vector3(0, 0, -a), Vector3(0.943 * a, 0, a / 3), Vector3(-0.471 * a, 0.816 * a, a / 3), Vector3(-0.471 * a, -0.816 * a, a / 3)]
mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=7800, frictionAngle=math.atan(0.5)))
ball = O.bodies.append(utils.sphere((0.13, 0.08, 0.012), 0.01, material=mat))
O.bodies[ball].state.vel = Vector3(0, 0, -0.5)
poly = PolyhedraGpuEngine(dilationRadius=0.01, restitution=e, backend="cpu", gravity=(0, 0, 0), label="poly")
poly.addStone(ball, tetra)
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], timeout=30, contactModel="polyhedra",
                             scheme=scheme, restitution=e, implicitTolerance=1e-4, label="coupling")
impulse = [Vector3.Zero]


def add_impulse():
    impulse[0] += coupling.totalForce * coupling.femDt


O.engines = [coupling, poly, PyRunner(command="add_impulse()", iterPeriod=50, initRun=False)]
O.dt = 2e-6
coupling.connect()
poly.initialize()  # the stone's body gets the dilated core's mass
check(coupling.subcycles == 50, f"{coupling.subcycles} DEM steps per window")
mass = O.bodies[ball].state.mass
# Steiner: the core adds its area times r_d and its mean-curvature integral times r_d^2, 2e-4 of the sphere here.
check(abs(mass - 7800 * 4 / 3 * math.pi * 0.01 ** 3) < 1e-3 * mass, f"stone mass {mass:.6f} kg: about a sphere of 10 mm")
O.run(50 * 120 + 1, True)  # 12 ms: 4 ms to the surface, ~1.7 ms of contact, away again
v1 = O.bodies[ball].state.vel
check(len(poly.contacts()) == 0 and v1[2] > 0, f"the stone rebounded and left the surface (v = {v1[2]:.5f} m/s)")
change = mass * (v1 - Vector3(0, 0, -0.5))
# Velocity Verlet's momentum change is the sum of the contact forces over the evaluations (no contact at either end),
# the same sum the windows' mean triangle forces times the window make; lumping keeps each total. Equal to round-off.
check((change + impulse[0]).norm() < 1e-9 * change.norm(),
      f"momentum change {change[2]:.9e} N s = -impulse sent to the FEM {-impulse[0][2]:.9e} N s")
# Restitution: Thornton et al.'s damping ratio for e reproduces e for a Hertz impact to 1e-4 (tests/kernels); the contact
# spans ~850 steps, whose discretisation of the contact's start and end changes e by O(dt/t_c) ~ 1e-3; the surface
# nodes (1 t on 1e9 N/m) move by 1e-8 m against an overlap of 1e-4 m. 5e-3 covers these.
check(abs(v1[2] / 0.5 - e) < 5e-3, f"rebound ratio {v1[2] / 0.5:.5f}, restitution e = {e}")
implicit_checks(coupling, smooth=True)
coupling.finalize()
fem.wait(10)
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")

# ---------------------------------------------------------------------------------------------------------------
# 3. Refused set-ups, before any connection: no PolyhedraGpuEngine, or two.
# ---------------------------------------------------------------------------------------------------------------
for engines, needle in (([], "holds 0"), ([PolyhedraGpuEngine(), PolyhedraGpuEngine()], "holds 2")):
    O.reset()
    engine = FemCouplingEngine(endpoint="ipc:///tmp/railcosim-nowhere.sock", material=FrictMat(), contactModel="polyhedra",
                               timeout=1)
    O.engines = engines + [engine]
    try:
        engine.connect()
        check(False, f"should refuse ({needle})")
    except Exception as error:
        check(needle in str(error) and "PolyhedraGpuEngine" in str(error), f"refused: {str(error)[:110]}")

print("polyhedra_surface_coupling:", "FAILED" if failures else "passed", flush=True)
sys.exit(1 if failures else 0)
