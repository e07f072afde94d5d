# YADE check: a sphere cluster of the shape library (a clump advanced by QuaternionIntegrator) on an FE surface served
# by the stand-in FEM, through the mesh contacts (FemCouplingEngine contactModel='meshContacts').
# 1. Rest: the cluster lands on the surface and comes to rest on several members. Oracles: the lumped nodal forces add up
#    to the clump's weight m g and their centroid lies under its centre of mass (moment balance at rest).
# 2. Impact without gravity, spinning, window-averaged forces: the clump's momentum change equals minus the impulse the
#    FEM received (sum over the windows of the sent nodal forces times the window). With the implicit scheme this holds
#    only if a repeated window restores the integrator's half-step state with the scene: otherwise the first step of each
#    repeated pass skips the corrector of the step before it and the stone gains or loses dt/2 F of momentum per pass.
# Run: ./railcosim yade yade_engines/checks/cluster_surface_coupling.py PATH/TO/railcosim_dummy_fem [SCHEME]
import math
import os
import subprocess
import sys
import uuid

import numpy as np

from railcosim.dem import run_steps

sys.path.insert(0, os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"))
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402

dummy_fem = sys.argv[1]
scheme = sys.argv[2] if len(sys.argv) > 2 else "justInTime"
failures = []


def check(condition, message):
    print(("ok:   " if condition else "FAIL: ") + message, flush=True)
    if not condition:
        failures.append(message)


def start_fem(dt, mass, stiffness):
    endpoint = f"ipc:///tmp/railcosim-check-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
    fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", "3", "--ny", "3", "--spacing", "0.1",
                            "--dt", str(dt), "--mass", str(mass), "--stiffness", str(stiffness), "--timeout", "30",
                            "--scheme", scheme])
    return fem, endpoint


library = ballast_clusters.loadShapeLibrary()


def library_stone(name, size, density):
    """A coarse library cluster at sieve size `size` [m], in its principal axes (pack_ballast.addClusterStone's input)."""
    shape = next(s for s in library["shapes"] if s["name"] == name)
    cluster = shape["clusters"]["coarse"]
    return {"rotation": np.eye(3), "spheres": cluster["spheres"] * size, "mass": density * cluster["volume"] * size ** 3,
            "principalInertia": density * cluster["principalInertia"] * size ** 5}


def scene(stone, centre, velocity, angular_velocity, gravity, damping, fem_dt, dt, average, nodes):
    fem, endpoint = start_fem(fem_dt, *nodes)
    O.reset()
    mat = O.materials.append(FrictMat(young=1e8, poisson=0.25, density=2600, frictionAngle=math.atan(0.6)))
    clump = pack_ballast.addClusterStone(stone, centre, O.materials[mat])
    O.bodies[clump].state.vel = velocity
    O.bodies[clump].state.angVel = angular_velocity
    coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], timeout=30, contactModel="meshContacts",
                                 scheme=scheme, restitution=0.3, averageForces=average, implicitTolerance=1e-4,
                                 label="coupling")
    O.engines = [ForceResetter(), coupling, QuaternionIntegrator(gravity=gravity, damping=damping)]
    O.dt = dt
    coupling.connect()
    return fem, coupling, clump


def finish(fem, coupling):
    if scheme == "implicit":
        check(coupling.window < coupling.implicitPasses, f"{coupling.implicitPasses} passes over {coupling.window} windows")
        check(abs(O.time - O.iter * O.dt) <= 1e-9 * O.time, f"O.time {O.time:.9f} s = O.iter x O.dt {O.iter * O.dt:.9f} s")
    coupling.finalize()
    fem.wait(10)
    check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")


g = 9.81
# 1. Rest: blocky_a at 35 mm (10 spheres) on 3 x 3 spring nodes (2e5 N/m, 0.05 kg each, undamped). Without rolling
#    resistance a cluster rocks on its round members for seconds; numerical damping (Cundall, 0.3) brings it to rest,
#    where it changes no force.
stone = library_stone("blocky_a", 0.035, 2600)
bottom = min(s[2] - s[3] for s in stone["spheres"])  # lowest point of the cluster below its centre of mass
fem, coupling, clump = scene(stone, (0.12, 0.09, 0.001 - bottom), Vector3.Zero, Vector3.Zero, (0, 0, -g), 0.3, 2e-4,
                             2e-5, False, (0.05, 2.0e5))
check(coupling.subcycles == 10, f"{coupling.subcycles} DEM steps per window")
O.run(10 * 2000, True)  # 0.4 s
sums = {"force": Vector3.Zero, "mx": 0.0, "my": 0.0, "n": 0, "contacts": 0}
for _ in range(300):
    run_steps(10)
    forces, positions = coupling.nodalForces, coupling.nodePositions
    sums["force"] += sum(forces, Vector3.Zero)
    sums["mx"] += sum(f[2] * x[0] for f, x in zip(forces, positions))
    sums["my"] += sum(f[2] * x[1] for f, x in zip(forces, positions))
    sums["contacts"] = max(sums["contacts"], coupling.surfaceContacts)
    sums["n"] += 1
n = sums["n"]
state = O.bodies[clump].state
weight = state.mass * g
mean = sums["force"] / n
check(state.vel.norm() < 1e-3, f"the cluster is at rest (|v| = {state.vel.norm():.1e} m/s)")
check(sums["contacts"] >= 2, f"it rests on {sums['contacts']} of its members")
# As in two_facet_round_trip: the undamped springs keep vibrating; over 300 windows the mean is within 1 %.
check(abs(mean[2] + weight) < 0.01 * weight, f"mean nodal force {mean[2]:.5f} N = -m g {-weight:.5f} N")
centroid = (sums["mx"] / n / mean[2], sums["my"] / n / mean[2])
# The resultant of the member contacts passes through the clump's centre of mass at rest; 1 mm covers the sway.
check(abs(centroid[0] - state.pos[0]) < 1e-3 and abs(centroid[1] - state.pos[1]) < 1e-3,
      f"nodal force centroid ({centroid[0]:.4f}, {centroid[1]:.4f}) under the centre of mass ({state.pos[0]:.4f}, {state.pos[1]:.4f})")
finish(fem, coupling)

# 2. Impact: the same cluster at 0.5 m/s, tumbling at 20 rad/s, on heavy stiff nodes (1 t, 1e9 N/m), no gravity.
v0 = Vector3(0.1, 0.0, -0.5)
fem, coupling, clump = scene(stone, (0.12, 0.09, 0.001 - bottom), v0, Vector3(5, 20, 0), (0, 0, 0), 0.0, 1e-4, 2e-6,
                             True, (1e3, 1e9))
impulse = [Vector3.Zero]


def add_impulse():
    impulse[0] += coupling.totalForce * coupling.femDt


O.engines = O.engines + [PyRunner(command="add_impulse()", iterPeriod=coupling.subcycles, initRun=False)]
mass = O.bodies[clump].state.mass
O.run(coupling.subcycles * 300 + 1, True)  # 30 ms: 2 ms to the surface, contacts, away again
v1 = O.bodies[clump].state.vel
check(coupling.surfaceContacts == 0 and v1[2] > 0, f"the cluster bounced off (v_z = {v1[2]:.4f} m/s, {coupling.surfaceContacts} contacts)")
check(impulse[0][2] < -1e-3, f"the FEM received an impulse of {impulse[0][2]:.5f} N s")
change = mass * (v1 - v0)
# Velocity Verlet in the clump: the momentum change is dt times the sum of the member forces over the evaluations; the
# window means the FEM received times the window make the same sum, and lumping keeps each total: round-off only.
check((change + impulse[0]).norm() < 1e-9 * change.norm(),
      f"momentum change {change} N s = -impulse sent to the FEM {-impulse[0]} N s "
      f"(difference {(change + impulse[0]).norm():.2e})")
finish(fem, coupling)

print("cluster_surface_coupling:", "FAILED" if failures else "passed", flush=True)
sys.exit(1 if failures else 0)
