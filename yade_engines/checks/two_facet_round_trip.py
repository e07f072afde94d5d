# YADE check: a sphere resting on a two-triangle surface served by the stand-in FEM participant.
# Oracles: the lumped nodal forces add up to the sphere's weight, their centroid lies under the sphere
# (moment conservation), and the surface comes back displaced by F/k at every node (the stand-in's
# nodes are independent springs), with the facets following the received node positions.
# With the implicit scheme also: every window converges, windows are repeated (more passes than windows),
# and the rolled-back clock stays consistent (O.time = O.iter * O.dt after thousands of rollbacks).
# BODY "clump": a two-sphere cluster instead of the sphere (meshContacts contacts push on each member, the
# clump integrates them): the same weight and moment balance about the clump's centre of mass, two contacts.
# Run: ./railcosim yade yade_engines/checks/two_facet_round_trip.py PATH/TO/railcosim_dummy_fem [facets|meshContacts|hierarchy (former name of meshContacts)] [SCHEME] [sphere|clump]
import os
import subprocess
import sys
import uuid

from railcosim.dem import run_steps

dummy_fem = sys.argv[1]
contact_model = sys.argv[2] if len(sys.argv) > 2 else "facets"
scheme = sys.argv[3] if len(sys.argv) > 3 else "justInTime"
body_kind = sys.argv[4] if len(sys.argv) > 4 else "sphere"
stiffness = 2.0e5  # N/m per node
endpoint = f"ipc:///tmp/railcosim-check-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", "2", "--ny", "2", "--spacing", "0.2",
                        "--dt", "2e-4", "--mass", "0.05", "--stiffness", str(stiffness), "--timeout", "30",
                        "--scheme", scheme])
failures = []


def check(condition, message):
    print(("ok:   " if condition else "FAIL: ") + message, flush=True)
    if not condition:
        failures.append(message)


radius, centre_xy = 0.02, (0.13, 0.06)
mat = O.materials.append(FrictMat(young=5e7, poisson=0.3, density=7800, frictionAngle=0.5))
if body_kind == "clump":
    # Two touching spheres along x, centred on centre_xy: the cluster rests on both.
    members = [utils.sphere((centre_xy[0] + dx, centre_xy[1], radius * 1.01), radius, material=mat) for dx in (-radius, radius)]
    sphere, member_ids = O.bodies.appendClumped(members)
else:
    sphere = O.bodies.append(utils.sphere((centre_xy[0], centre_xy[1], radius * 1.01), radius, material=mat))
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], timeout=30, contactModel=contact_model,
                             scheme=scheme, implicitTolerance=1e-4, label="coupling")
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
             InteractionLoop([Ig2_Facet_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             coupling, NewtonIntegrator(damping=0.6, gravity=(0, 0, -9.81))]
O.dt = 2e-5
coupling.connect()
check(len(coupling.triangles) == 2 and len(coupling.nodePositions) == 4, "two triangles on four nodes received")
check(len(coupling.facetIds) == (2 if contact_model == "facets" else 0), f"{len(coupling.facetIds)} facet bodies ({contact_model})")
check(coupling.subcycles == 10, f"sub-cycling ratio femDt/O.dt = 10 (got {coupling.subcycles})")

# Average over the last windows: the stand-in's springs are undamped, so a small vibration remains.
sums = {"force": Vector3.Zero, "moment_x": 0.0, "moment_y": 0.0, "spring": 0.0, "count": 0}
O.run(10 * 1500 + 1, True)
for _ in range(200):
    run_steps(10)
    forces, positions = coupling.nodalForces, coupling.nodePositions
    total = sum(forces, Vector3.Zero)
    sums["force"] += total
    sums["moment_x"] += sum(f[2] * x[0] for f, x in zip(forces, positions))
    sums["moment_y"] += sum(f[2] * x[1] for f, x in zip(forces, positions))
    sums["count"] += 1
coupling.finalize()
fem.wait(10)

n = sums["count"]
weight = O.bodies[sphere].state.mass * 9.81
mean_force = sums["force"] / n
# 1 % leaves room for the residual vibration of the undamped springs; lumping itself is exact.
check(abs(mean_force[2] + weight) < 0.01 * weight, f"total nodal force {mean_force[2]:.5f} N = -weight {-weight:.5f} N")
centroid = (sums["moment_x"] / n / mean_force[2], sums["moment_y"] / n / mean_force[2])
sphere_pos = O.bodies[sphere].state.pos
# The contact point is the sphere's foot; 1 mm covers its sway on the vibrating surface.
check(abs(centroid[0] - sphere_pos[0]) < 1e-3 and abs(centroid[1] - sphere_pos[1]) < 1e-3,
      f"force centroid {centroid} under the {body_kind} ({sphere_pos[0]:.4f}, {sphere_pos[1]:.4f})")
# Round trip: the node positions received back are z = F/k (springs at rest under the sent forces).
for i, (f, x) in enumerate(zip(coupling.nodalForces, coupling.nodePositions)):
    expected = f[2] / stiffness
    check(abs(x[2] - expected) <= 0.05 * weight / stiffness, f"node {i}: z = {x[2]:.3e} m, F/k = {expected:.3e} m")
# The facets follow the nodes: facet vertex in world frame = node position at the same instant.
if contact_model == "facets":
    tri = coupling.triangles[0]
    b = O.bodies[coupling.facetIds[0]]
    world = [b.state.pos + b.shape.vertices[j] for j in range(3)]
    gap = max((world[j] - coupling.nodePositions[tri[j]]).norm() for j in range(3))
    check(gap < 1e-9 + 2 * O.dt * max(v.norm() for v in coupling.nodeVelocities), f"facet vertices on the nodes (gap {gap:.2e} m)")
else:
    expected_contacts = 2 if body_kind == "clump" else 1
    check(coupling.surfaceContacts == expected_contacts,
          f"{expected_contacts} {contact_model} contact(s) under the {body_kind} (got {coupling.surfaceContacts})")
if scheme == "implicit":
    windows = coupling.window
    check(coupling.unconvergedWindows == 0, f"every window converged ({coupling.unconvergedWindows} did not)")
    check(windows < coupling.implicitPasses <= coupling.implicitMaxIterations * windows,
          f"{coupling.implicitPasses} passes over {windows} windows (some repeated, at most {coupling.maxWindowPasses} each)")
    # Each repeated window winds O.iter and O.time back together; rounding of the summed dt is all that may differ.
    check(abs(O.time - O.iter * O.dt) <= 1e-9 * O.time, f"O.time {O.time:.9f} s = O.iter x O.dt {O.iter * O.dt:.9f} s")
    check(coupling.checkpointTime > 0, f"checkpoints cost {coupling.checkpointTime:.3f} s")
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")
print("two_facet_round_trip:", "FAILED" if failures else "passed", flush=True)
sys.exit(1 if failures else 0)
