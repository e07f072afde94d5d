"""YADE check of QuaternionIntegrator: R1–R4 (R3/R4 with clump fibres), kinematic bodies, blocked DOFs; NewtonIntegrator peer.

USAGE:   ./railcosim yade yade_engines/checks/quaternion_integrator.py [--peer-only]
OUTPUTS: one line per case (error measures) and exit status 0 when every QuaternionIntegrator case passes;
         --peer-only runs NewtonIntegrator alone (e.g. with Debian's YADE, which lacks the railcosim plugin).
Oracles and tolerances are those of tests/rotation (kernels): R1 ω'_x = sin 50t, ω'_y = cos 50t (Irazábal
2017 eq. 5.56, erratum 15); R2 θ = (1e5/I)(eᵗ − t − 1) (eq. 5.57); R3 total energy constant (no dissipation).
Takes about 20 s.
"""
import math
import sys

import yade
from yade import Quaternion, Vector3, utils

from railcosim.dem import run_steps

O = yade.O
failures = []


def check(label, value, limit, integrator):
    passed = value < limit
    ours = integrator.startswith("QuaternionIntegrator")
    if "direct" in integrator:
        verdict = "comparison only" + ("" if passed else ", outside limit as expected")
    elif ours:
        verdict = "ok" if passed else "FAIL"
    else:
        verdict = "peer, within limit" if passed else "peer, outside limit"
    print("%-36s %-36s %.3e (limit %.1e) %s" % (label, integrator, value, limit, verdict))
    if not passed and ours and "direct" not in integrator:
        failures.append(label + " " + integrator)


def integrators():
    peer = [("NewtonIntegrator(damping=0)", lambda: yade.NewtonIntegrator(damping=0))]
    if "--peer-only" in sys.argv or not hasattr(yade, "QuaternionIntegrator"):
        return peer
    return [("QuaternionIntegrator(%s)" % s, (lambda s=s: yade.QuaternionIntegrator(scheme=s)))
            for s in ("zhaoVanWachem", "rk4", "direct")] + peer


def r1_free_precession(name, make):
    """Aspherical body, inertia (2, 2, 1), ω0 = (0, 1, 100), Δt = 1e-3 s, 0.5 s; max |ω' − ω'_exact|."""
    O.reset()
    body = utils.sphere((0, 0, 0), 0.5, fixed=False)
    O.bodies.append(body)
    body.aspherical = True
    body.state.mass = 1.0
    body.state.inertia = Vector3(2, 2, 1)
    body.state.blockedDOFs = "xyz"
    body.state.angVel = Vector3(0, 1, 100)
    body.state.angMom = Vector3(0, 2, 100)  # NewtonIntegrator's aspherical schemes advance angMom, not angVel
    O.engines = [yade.ForceResetter(), make()]
    O.dt = 1e-3
    worst = 0.0
    for step in range(1, 501):
        O.step()
        # Both integrators leave the mid-step angular velocity in State.angVel: compare at t − Δt/2.
        t = (step - 0.5) * O.dt
        body_omega = body.state.ori.conjugate() * body.state.angVel
        exact = Vector3(math.sin(50 * t), math.cos(50 * t), 100)
        worst = max(worst, (body_omega - exact).norm())
    # Kernel test budget 0.0104 rad/s for the phase error, plus the first-order mid-step estimate
    # ½Δt·|ω̇'| ≈ 0.025 rad/s is not an error of the scheme but of comparing at t − Δt/2: 0.05 covers both.
    check("R1 max |w' - exact| [rad/s]", worst, 0.05, name)


def r2_sphere_torque(name, make):
    """Sphere R = 1 m, ρ = 1100, T = (0, 1e5 eᵗ, 0), Δt = 1e-4 s, 1 s; |q − q_exact|."""
    O.reset()
    material = O.materials.append(yade.FrictMat(density=1100))
    body = utils.sphere((0, 0, 0), 1.0, material=material)
    O.bodies.append(body)
    body.state.blockedDOFs = "xyz"
    O.engines = [yade.ForceResetter(),
                 yade.PyRunner(iterPeriod=1, initRun=True, command="O.forces.addT(0, Vector3(0, 1e5 * math.exp(O.time), 0))"),
                 make()]
    O.dt = 1e-4
    O.run(10000, True)
    inertia = body.state.inertia[1]
    angle = 1e5 / inertia * (math.exp(O.time) - O.time - 1)
    exact = Quaternion(Vector3(0, 1, 0), angle)
    q = body.state.ori
    error = min(math.sqrt(sum((q[i] - exact[i]) ** 2 for i in range(4))),
                math.sqrt(sum((q[i] + exact[i]) ** 2 for i in range(4))))
    # Velocity Verlet (our engine): kernel estimate 6e-8, bound 1e-6 as in the kernel test. NewtonIntegrator's
    # leapfrog starts with a full kick, ω^{1/2} = Δt T^0/I, a first-order offset of ½Δt·θ'(1 s) ≈ 3e-3 rad.
    check("R2 |q - q_exact| at 1 s", error, 1e-6, name)


def bouncing_fibres(name, make, label, axis, centres, velocity, duration):
    """Clumps of 5 touching spheres (r = 0.02 m) in the box [0, 1]^3 under gravity −z; Hertz, μ = 0, e = 1."""
    O.reset()
    fibre = O.materials.append(yade.FrictMat(young=5e7, poisson=0.35, density=1000, frictionAngle=0))
    wall = O.materials.append(yade.FrictMat(young=5e7, poisson=0.23, density=1000, frictionAngle=0))
    O.bodies.append(utils.aabbWalls([(0, 0, 0), (1, 1, 1)], thickness=0.1, material=wall))
    axis = axis.normalized()
    clumps = []
    for centre in centres:
        members = [utils.sphere(centre + axis * (k - 2) * 0.04, 0.02, material=fibre) for k in range(5)]
        clumpId, _ = O.bodies.appendClumped(members)  # touching spheres: no overlap to rasterise
        O.bodies[clumpId].state.vel = velocity
        clumps.append(O.bodies[clumpId])
    O.engines = [
        yade.ForceResetter(),
        yade.InsertionSortCollider([yade.Bo1_Sphere_Aabb(), yade.Bo1_Box_Aabb()], verletDist=0.002),
        yade.InteractionLoop([yade.Ig2_Sphere_Sphere_ScGeom(), yade.Ig2_Box_Sphere_ScGeom()],
                             [yade.Ip2_FrictMat_FrictMat_MindlinPhys()],
                             [yade.Law2_ScGeom_MindlinPhys_Mindlin()]),
        make(),
    ]
    O.engines[-1].gravity = (0, 0, -9.81)
    O.dt = 2e-6

    def energy():
        total = sum(0.4 * i.phys.normalForce.norm() * i.geom.penetrationDepth for i in O.interactions
                    if i.isReal and i.geom.penetrationDepth > 0)
        for clump in clumps:
            s = clump.state
            body_omega = s.ori.conjugate() * s.angVel
            total += 0.5 * s.mass * s.vel.squaredNorm() + s.mass * 9.81 * s.pos[2]
            total += 0.5 * sum(s.inertia[i] * body_omega[i] ** 2 for i in range(3))
        return total

    initial = energy()
    worst = 0.0
    chunks = 200
    steps = int(round(duration / O.dt / chunks))
    spin = 0.0
    for _ in range(chunks):
        run_steps(steps)
        worst = max(worst, abs(energy() - initial) / initial)
        spin = max([spin] + [c.state.angVel.norm() for c in clumps])
    # Leapfrog energy evaluated with mid-step velocities carries an O(Δt) offset of order |F|·|v|·Δt/E0
    # ≈ 1e-5 at impact; the thesis criterion is 0.3 %.
    check(label + " max |E - E0|/E0", worst, 3e-3, name)
    if spin < 1.0:
        failures.append("%s %s: the fibres did not start to spin (|w| = %.3g rad/s)" % (label, name, spin))


def r3_single_fibre(name, make):
    # x' along (0.86603, 0, −0.5): −30° from the horizontal, so one end lands first.
    bouncing_fibres(name, make, "R3 clump fibre", Vector3(0.86603, 0, -0.5), [Vector3(0.5, 0.5, 0.35)],
                    Vector3(0, 0, 0), 0.4)


def r4_nine_fibres(name, make):
    # Nine fibres at mid-height along x in the plane y = 0.5, x' at −75° from the horizontal, v0 = (1, −1, 0)
    # in our axes (the thesis' [1, 0, −1] with its vertical axis unspecified): wall and fibre–fibre impacts.
    bouncing_fibres(name, make, "R4 nine clump fibres", Vector3(0.25882, 0, -0.96593),
                    [Vector3(0.1 + 0.1 * k, 0.5, 0.5) for k in range(9)], Vector3(1, -1, 0), 0.4)


def kinematics_and_blocked_dofs(name, make):
    """Fixed body with prescribed velocities moves exactly; blocked DOFs stay blocked; gravity acts on free ones."""
    O.reset()
    kinematic = utils.sphere((0, 0, 0), 0.1, fixed=True)
    kinematic.state.vel, kinematic.state.angVel = Vector3(1, 0, 0), Vector3(0, 0, 2)
    falling = utils.sphere((5, 0, 0), 0.1)
    held = utils.sphere((10, 0, 0), 0.1)
    held.state.blockedDOFs = "zXY"  # no vertical motion, rotation about z only
    held.state.angVel = Vector3(3, 0, 1)  # the blocked x component is kept as prescribed
    O.bodies.append([kinematic, falling, held])
    O.engines = [yade.ForceResetter(),
                 yade.PyRunner(iterPeriod=1, initRun=True, command="O.forces.addT(2, Vector3(0, 0, 1))"), make()]
    O.engines[-1].gravity = (0, 0, -9.81)
    O.dt = 1e-3
    O.run(1000, True)
    t = O.time
    # Kinematic: x = v t and a rotation by 2t about z, exact up to round-off of 1000 steps (1e-12).
    error = (kinematic.state.pos - Vector3(t, 0, 0)).norm()
    error += (kinematic.state.ori.conjugate() * Quaternion(Vector3(0, 0, 1), 2 * t)).toAxisAngle()[1] % (2 * math.pi)
    # Free fall from rest: velocity Verlet is exact for constant acceleration, z = −g t²/2.
    error += abs(falling.state.pos[2] + 0.5 * 9.81 * t * t)
    # Held: no vertical motion; ω_x kept at 3; ω_z = 1 + T t/I at the half step (I = 2/5 m r²).
    inertia = held.state.inertia[2]
    error += abs(held.state.pos[2]) + abs(held.state.angVel[0] - 3)
    error += abs(held.state.angVel[2] - (1 + (t - 0.5 * O.dt) / inertia)) / (t / inertia)
    check("kinematic/blocked DOFs (sum of errors)", error, 1e-9, name)


for name, make in integrators():
    r1_free_precession(name, make)
    r2_sphere_torque(name, make)
    r3_single_fibre(name, make)
    r4_nine_fibres(name, make)
    kinematics_and_blocked_dofs(name, make)

if failures:
    print("FAILED: " + "; ".join(failures))
    sys.exit(1)
print("all QuaternionIntegrator checks passed")
sys.exit(0)
