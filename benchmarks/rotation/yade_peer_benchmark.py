"""Accuracy against cost inside YADE: QuaternionIntegrator schemes (when loaded) and stock NewtonIntegrator on R1 and R2.

USAGE:   yade -n -x benchmarks/rotation/yade_peer_benchmark.py OUTPUT.json
         (./railcosim yade ... for the build with the railcosim plugin; Debian's `yade` gives the peer alone)
OUTPUTS: OUTPUT.json with samples in the format of RotationBenchmark.cpp (test, scheme, timeStep, error,
         errorMeasure, wallSeconds, cpuSeconds), scheme names prefixed "yade:"; R1 times are per body (10000
         independent copies run together; YADE's per-step overhead is shared); R1 error is of the orientation, R2 has no timing (Python torque callback each step). Errors are taken at the end of the run (the phase errors grow
         monotonically, so this is close to the maximum over time used by the kernel benchmark).
"""
import json
import math
import sys
import time

import yade
from yade import Quaternion, Vector3, utils

O = yade.O


def candidates():
    version = getattr(yade.config, "version", "?") if hasattr(yade, "config") else "?"
    found = [("yade:NewtonIntegrator " + str(version), lambda: yade.NewtonIntegrator(damping=0))]
    if hasattr(yade, "QuaternionIntegrator"):
        found += [("yade:QuaternionIntegrator " + s, (lambda s=s: yade.QuaternionIntegrator(scheme=s)))
                  for s in ("zhaoVanWachem", "rk4", "direct")]
    return found


def timed_run(steps):
    wall, cpu = time.perf_counter(), time.process_time()
    O.run(steps, True)
    return time.perf_counter() - wall, time.process_time() - cpu


BODIES = 10000  # identical, independent copies: the integrator's cost dominates YADE's per-step overhead


def r1(make, dt):
    O.reset()
    for k in range(BODIES):
        body = utils.sphere((3.0 * k, 0, 0), 0.5)
        O.bodies.append(body)
        body.aspherical = True
        body.state.mass, body.state.inertia, body.state.blockedDOFs = 1.0, Vector3(2, 2, 1), "xyz"
        body.state.angVel, body.state.angMom = Vector3(0, 1, 100), Vector3(0, 2, 100)
    body = O.bodies[0]
    O.engines = [yade.ForceResetter(), make()]
    O.dt = dt
    steps = int(round(0.5 / dt))
    wall, cpu = timed_run(steps)
    wall, cpu = wall / BODIES, cpu / BODIES  # per body, comparable with the single-body kernel benchmark
    # Orientation error: whether State.angVel holds a mid-step or a full-step value differs between the
    # integrators (and would bias an angular-velocity comparison by ½Δt|ω̇'|), State.ori is at t_N for all.
    # Oracle: q(t_N) I' ω'_exact(t_N) q(t_N)* must equal H0 = (0, 2, 100).
    t = steps * dt
    momentum = body.state.ori * Vector3(2 * math.sin(50 * t), 2 * math.cos(50 * t), 100)
    error = (momentum - Vector3(0, 2, 100)).norm() / Vector3(0, 2, 100).norm()
    return error, wall, cpu


def r2(make, dt):
    O.reset()
    material = O.materials.append(yade.FrictMat(density=1100))
    body = utils.sphere((0, 0, 0), 1.0, material=material)
    O.bodies.append(body)
    body.state.blockedDOFs = "xyz"
    O.engines = [yade.ForceResetter(),
                 yade.PyRunner(iterPeriod=1, initRun=True, command="O.forces.addT(0, Vector3(0, 1e5 * math.exp(O.time), 0))"),
                 make()]
    O.dt = dt
    wall, cpu = timed_run(int(round(1.0 / dt)))
    wall = cpu = float("nan")  # one body plus a Python torque callback per step: the time says nothing
    angle = 1e5 / body.state.inertia[1] * (math.exp(O.time) - O.time - 1)
    exact = Quaternion(Vector3(0, 1, 0), angle)
    q = body.state.ori
    error = 2 * min(math.sqrt(sum((q[i] - exact[i]) ** 2 for i in range(4))),
                    math.sqrt(sum((q[i] + exact[i]) ** 2 for i in range(4))))  # ≈ angle error
    return error, wall, cpu


samples = []
for name, make in candidates():
    for dt in (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4):
        error, wall, cpu = r1(make, dt)
        samples.append({"test": "R1 (YADE)", "scheme": name, "timeStep": dt, "error": error, "wallSeconds": wall,
                        "cpuSeconds": cpu, "errorMeasure": "|q I'w'_exact q* - H0|/|H0| [-] at 0.5 s"})
    for dt in (1e-2, 5e-3, 2e-3, 1e-3, 5e-4):
        error, wall, cpu = r2(make, dt)
        samples.append({"test": "R2 (YADE)", "scheme": name, "timeStep": dt, "error": error, "wallSeconds": wall,
                        "cpuSeconds": cpu, "errorMeasure": "|theta - theta_exact| [rad] at 1 s"})
for s in samples:
    print("%-9s %-44s dt %-9.3g error %-11.4g wall %-10.4g cpu %.4g s per body and run"
          % (s["test"], s["scheme"], s["timeStep"], s["error"], s["wallSeconds"], s["cpuSeconds"]))
output = [a for a in sys.argv[1:] if a.endswith(".json")]
if output:
    with open(output[0], "w") as handle:
        json.dump({"description": "Rotation schemes inside YADE (R1, R2)", "samples": samples}, handle, indent=1)
