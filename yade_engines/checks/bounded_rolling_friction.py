# YADE check of BoundedRollingFrictionEngine with the ballast contact law: Irazábal's BROF benchmarks 1 and 2.
# Run: ./railcosim yade yade_engines/checks/bounded_rolling_friction.py [newton|quaternion]   (a few seconds; exit 0 when all pass)
# Oracles: rigid-body solutions of Irazábal 2017's BROF benchmarks (Table 5.2 material, R = 0.05 m):
# flat roll-out stops at t = 0.5097 s, x = 0.18836 m; on a 10° slope η_r = 0.1 rolls back, 0.2 and 0.4 stay
# at the rigid-body distance (the resting torque m g R sin 10° is asserted in tests/kernels). Tolerances: 2 %
# (contact compliance, as in the kernel test).
import math
import sys

from yade import O, utils

failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message)
    if not condition:
        failures.append(message)


RADIUS = 0.05
G = 9.81
# "newton" (YADE's stock NewtonIntegrator) or "quaternion" (railcosim's QuaternionIntegrator, ZvW scheme)
INTEGRATOR = sys.argv[1] if len(sys.argv) > 1 else "newton"


def integrator(damping, gravity):
    if INTEGRATOR == "quaternion":
        return QuaternionIntegrator(scheme="zhaoVanWachem", damping=damping, gravity=gravity)
    return NewtonIntegrator(damping=damping, gravity=gravity)


def scene(eta, slope_degrees, rolling_start, damping=0.0):
    O.reset()
    mat = O.materials.append(BallastMat(young=4e7, poisson=0.49, density=1056, restitution=0.2,
                                        frictionAngle=math.atan(0.8), rollingFriction=eta))
    wall = O.bodies.append(utils.wall(0, axis=2, material=mat))
    mass = 1056 * 4 / 3 * math.pi * RADIUS ** 3
    beta = math.radians(slope_degrees)
    # start at the static Hertz overlap under the normal weight (rigid wall: E* = E/(1 − ν²))
    e_star = 4e7 / (1 - 0.49 ** 2)
    overlap = (3 * mass * G * math.cos(beta) / (4 * e_star * math.sqrt(RADIUS))) ** (2.0 / 3.0)
    ball = O.bodies.append(utils.sphere((0, 0, RADIUS - overlap), RADIUS, material=mat))
    O.bodies[ball].state.vel = (1.0, 0, 0)
    if rolling_start:
        O.bodies[ball].state.angVel = (0, 1.0 / RADIUS, 0)
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                        [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
        BoundedRollingFrictionEngine(label="brof"),
        integrator(damping, (-G * math.sin(beta), 0, -G * math.cos(beta))),
    ]
    O.dt = 5e-5
    return wall, ball, mass


# Benchmark 1: flat roll-out, slip then rolling with a = −(5/7) η_r g.
wall, ball, mass = scene(0.2, 0.0, False)
stop_time = stop_x = None
while O.time < 1.2:
    O.step()
    if stop_time is None and O.bodies[ball].state.vel[0] <= 0:
        stop_time, stop_x = O.time, O.bodies[ball].state.pos[0]
check(stop_time is not None and abs(stop_time / 0.5097 - 1) < 0.02, f"flat: stops at t = {stop_time} s (0.5097)")
check(stop_x is not None and abs(stop_x / 0.18836 - 1) < 0.02, f"flat: stops at x = {stop_x} m (0.18836)")
spin = O.bodies[ball].state.angVel.norm()
check(spin < 1e-9, f"flat: spin held at zero after stopping (|ω| = {spin:.2e} rad/s)")

# Benchmark 2: 10° slope, pure rolling start up the slope.
for eta, should_stay in ((0.1, False), (0.2, True), (0.4, True)):
    wall, ball, mass = scene(eta, 10.0, True)
    top = 0.0
    while O.time < 1.2:
        O.step()
        top = max(top, O.bodies[ball].state.pos[0])
    final = O.bodies[ball].state.pos[0]
    stayed = abs(final - top) < 1e-4
    check(stayed == should_stay, f"slope η_r = {eta}: top {top:.4f} m, final {final:.4f} m, "
                                 f"{'stays' if stayed else 'rolls back'} (expected {'stay' if should_stay else 'roll back'})")
    if should_stay:
        beta = math.radians(10)
        expected_top = 1.0 / (2 * 5 / 7 * G * (math.sin(beta) + eta * math.cos(beta)))
        check(abs(top / expected_top - 1) < 0.02, f"slope η_r = {eta}: top at {top:.4f} m ({expected_top:.4f})")
        check(O.bodies[ball].state.angVel.norm() < 1e-9, f"slope η_r = {eta}: spin held at zero")

# The engine refuses Cundall damping, which would reverse the spins it stops.
scene(0.2, 0.0, False, damping=0.2)
try:
    O.step()
    check(False, "NewtonIntegrator(damping=0.2) must be refused")
except Exception as error:
    check("damping" in str(error), f"Cundall damping refused: {str(error)[:80]}...")

print("FAILURES:", len(failures))
sys.exit(1 if failures else 0)
