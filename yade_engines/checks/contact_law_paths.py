# YADE check: the one contact law on its three YADE paths gives the closed forms of the two path scenarios.
# Paths: the pair law (Law2_ScGeom_BallastPhys_Ballast, a sphere on a BallastMat wall), the sphere-FE-surface
# contacts (FemCouplingEngine, contactModel='meshContacts', a flat surface served by the stand-in FEM participant,
# made rigid: springs of 1e16 N/m per node under 1e10 kg) and a BallastMat stone of PolyhedraGpuEngine on the same
# coupled surface (contactModel='polyhedra'; a point-like core dilated by R is the sphere). Scenarios and tolerances
# are those of tests/kernels/ContactLawScenarios.hpp (the kernel and the polyhedra library run them in C++):
#  1. a granite sphere (Tolomeo & McDowell 2022 Table 1: E = 60 GPa, nu = 0.25, D_f = 2.13, h = 26.1 um, R = 4.72 mm)
#     on a flat of the same granite, elasto-plastic Pohrt-Popov, approached at 1e-8 m per step until F >= 500 N and
#     withdrawn at the same rate: peak force on the virgin curve, force vanishing at the closed-form plastic overlap
#     delta_p = delta_max - (3 F_max / (4 E* sqrt(R*)))^(2/3), Hertzian unloading about delta_p;
#  2. the smooth granite sphere dropped on the flat at 0.5 m/s with restitution 0.5: rebound / approach = 0.5.
# The polyhedra engine cannot prescribe a stone's motion: there the rough stone approaches freely and its loading
# half-contact is compared with the virgin curve (force at every window's last evaluation, as in the cycle's peak).
# Run: ./railcosim yade yade_engines/checks/contact_law_paths.py PATH/TO/railcosim_dummy_fem   (about 3 s)
import math
import os
import subprocess
import sys
import uuid

from railcosim.dem import run_steps
from yade import O, utils

dummy_fem = sys.argv[1]
failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message, flush=True)
    if not condition:
        failures.append(message)


# --- the scenarios (tests/kernels/ContactLawScenarios.hpp) --------------------------------------------------------
E, NU, DENSITY, MU = 60e9, 0.25, 2650.0, 0.7
FRACTAL, ROUGHNESS, RADIUS = 2.13, 2.61e-5, 4.72e-3
CYCLE_SPEED, CYCLE_DT, CYCLE_PEAK = 0.01, 1e-6, 500.0
CYCLE_STEP = CYCLE_SPEED * CYCLE_DT
IMPACT_E, IMPACT_SPEED, IMPACT_DT = 0.5, 0.5, 2e-8
E_STAR = E / (2 * (1 - NU ** 2))  # like materials; against the flat R* = R
PEAK_FORCE_TOLERANCE, PLASTIC_STEP_TOLERANCE, UNLOADING_TOLERANCE, RESTITUTION_TOLERANCE = 1e-10, 0.01, 1e-10, 1e-3


def virgin_force(overlap):
    """Pohrt-Popov virgin curve (Tolomeo & McDowell 2022 eqs. 1-5, eq. 5 exponent 1/(0.2567 D_f)), integrated from F = 0."""
    gamma = 0.2567 * FRACTAL
    area = 0.75 * math.pi ** 1.5 * RADIUS * ROUGHNESS * (20 / (math.pi ** 1.5 * FRACTAL)) ** (1 / gamma)
    transition_force = 4 * E_STAR / (3 * RADIUS) * (area / math.pi) ** 1.5
    prefactor = math.pi / 10 * FRACTAL * E_STAR * math.sqrt(area) / (ROUGHNESS * E_STAR * math.sqrt(area)) ** gamma
    transition_overlap = transition_force ** (1 - gamma) / ((1 - gamma) * prefactor)
    if overlap < transition_overlap:
        return ((1 - gamma) * prefactor * overlap) ** (1 / (1 - gamma))
    shift = transition_overlap - (3 * transition_force / (4 * E_STAR * math.sqrt(RADIUS))) ** (2 / 3)
    return 4 / 3 * E_STAR * math.sqrt(RADIUS) * (overlap - shift) ** 1.5


def plastic_overlap(peak_overlap, peak_force):
    return peak_overlap - (3 * peak_force / (4 * E_STAR * math.sqrt(RADIUS))) ** (2 / 3)


def unloading_force(overlap, plastic):
    return 4 / 3 * E_STAR * math.sqrt(RADIUS) * (overlap - plastic) ** 1.5 if overlap > plastic else 0.0


class CycleRecorder:
    """Fed with every step of the cycle: that step's overlap and normal force (as the C++ CycleRecorder)."""

    def __init__(self):
        self.peak_overlap = self.peak_force = 0.0
        self.release_overlap = self.zero_overlap = 0.0
        self.middle = None
        self.done = False

    def sample(self, overlap, force, unloading):
        # The sphere moves after the forces of a step, so it reaches one step deeper than where it turns.
        if not unloading or overlap > self.peak_overlap:
            if overlap > self.peak_overlap:
                self.peak_overlap, self.peak_force = overlap, force
            return
        if self.done:
            return
        middle = self.peak_overlap - 0.5 * (self.peak_overlap - plastic_overlap(self.peak_overlap, self.peak_force))
        if force > 0:
            self.release_overlap = overlap
            if self.middle is None and overlap <= middle:
                self.middle = (overlap, force)
        else:
            self.zero_overlap, self.done = overlap, True

    def report(self, path):
        check(self.done and self.middle is not None, f"{path}: the cycle ran to zero force")
        if not self.done or self.middle is None:
            return
        expected = plastic_overlap(self.peak_overlap, self.peak_force)
        peak_error = abs(self.peak_force / virgin_force(self.peak_overlap) - 1)
        check(peak_error < PEAK_FORCE_TOLERANCE, f"{path}: F_max {self.peak_force:.6f} N at delta_max "
              f"{self.peak_overlap:.6e} m on the virgin curve (rel. error {peak_error:.1e} < {PEAK_FORCE_TOLERANCE})")
        outside = max(expected - self.release_overlap, self.zero_overlap - expected, 0.0) / CYCLE_STEP
        check(outside <= PLASTIC_STEP_TOLERANCE, f"{path}: force vanishes between {self.zero_overlap:.6e} and "
              f"{self.release_overlap:.6e} m, closed-form delta_p {expected:.6e} m ({outside:.3f} steps outside)")
        overlap, force = self.middle
        unloading_error = abs(force / unloading_force(overlap, expected) - 1)
        check(unloading_error < UNLOADING_TOLERANCE, f"{path}: unloading force {force:.4f} N at {overlap:.4e} m = "
              f"Hertz about delta_p (rel. error {unloading_error:.1e} < {UNLOADING_TOLERANCE})")


def run_cycle(sphere, step):
    """Drives the prescribed sphere through the cycle; step() advances one step and returns (overlap, force) of that
    step's contact, or None before the contact."""
    recorder, unloading = CycleRecorder(), False
    for _ in range(100000):
        sample = step()
        if sample is None:
            continue
        recorder.sample(*sample, unloading)
        if recorder.done:
            break
        if not unloading and sample[1] >= CYCLE_PEAK:
            unloading = True
            O.bodies[sphere].state.vel = (0, 0, CYCLE_SPEED)
    return recorder


def report_restitution(path, rebound):
    achieved = rebound / IMPACT_SPEED
    check(abs(achieved / IMPACT_E - 1) < RESTITUTION_TOLERANCE,
          f"{path}: restitution {achieved:.5f} = {IMPACT_E} (rel. {RESTITUTION_TOLERANCE})")


def granite(rough):
    if rough:  # e = 1: no dashpot in the quasi-static cycle
        return BallastMat(young=E, poisson=NU, density=DENSITY, frictionAngle=math.atan(MU), restitution=1.0,
                          roughnessFractalDim=FRACTAL, roughnessRms=ROUGHNESS, plasticUnloading=True)
    return BallastMat(young=E, poisson=NU, density=DENSITY, frictionAngle=math.atan(MU), restitution=IMPACT_E)


# --- path 1: YADE pairs (sphere on a BallastMat wall at z = 0) ------------------------------------------------------
def pair_engines():
    return [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
            InteractionLoop([Ig2_Wall_Sphere_ScGeom()], [Ip2_BallastMat_BallastMat_BallastPhys()],
                            [Law2_ScGeom_BallastPhys_Ballast()]),
            NewtonIntegrator(damping=0, gravity=(0, 0, 0))]


O.reset()
material = O.materials.append(granite(True))
wall = O.bodies.append(utils.wall(0, axis=2, sense=1, material=material))
sphere = O.bodies.append(utils.sphere((0, 0, RADIUS + 0.5 * CYCLE_STEP), RADIUS, material=material, fixed=True))
O.bodies[sphere].state.vel = (0, 0, -CYCLE_SPEED)
O.engines = pair_engines()
O.dt = CYCLE_DT


def pair_step():
    O.step()
    if not O.interactions.has(wall, sphere) or not O.interactions[wall, sphere].isReal:
        return None
    interaction = O.interactions[wall, sphere]
    return interaction.geom.penetrationDepth, interaction.phys.normalForce.norm()


recorder = run_cycle(sphere, pair_step)
check(O.interactions[wall, sphere].phys.contactLaw ==
      "pohrt_popov_plastic + viscous_restitution + stiffness_ratio + coulomb + none",
      f"pair law: {O.interactions[wall, sphere].phys.contactLaw}")
recorder.report("YADE pair")

O.reset()
material = O.materials.append(granite(False))
wall = O.bodies.append(utils.wall(0, axis=2, sense=1, material=material))
sphere = O.bodies.append(utils.sphere((0, 0, RADIUS + 1e-7), RADIUS, material=material))
O.bodies[sphere].state.vel = (0, 0, -IMPACT_SPEED)
O.engines = pair_engines()
O.dt = IMPACT_DT
touched = False
for _ in range(20000):
    O.step()
    real = O.interactions.has(wall, sphere) and O.interactions[wall, sphere].isReal
    touched = touched or (real and O.interactions[wall, sphere].phys.normalForce.norm() > 0)
    if touched and O.bodies[sphere].state.pos[2] > RADIUS:
        break
report_restitution("YADE pair", O.bodies[sphere].state.vel[2])


# --- path 2: sphere-FE-surface contacts (rigid stand-in surface at z = 0) -------------------------------------------
def surface_run(fem_dt, material_of):
    """Connects a coupled scene with one sphere over triangle 0 of a 0.2 m x 0.2 m two-triangle surface."""
    O.reset()
    endpoint = f"ipc:///tmp/railcosim-check-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
    fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", "2", "--ny", "2", "--spacing", "0.2",
                            "--dt", str(fem_dt), "--mass", "1e10", "--stiffness", "1e16", "--timeout", "30"])
    material = O.materials.append(material_of)
    coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[material], timeout=30,
                                 contactModel="meshContacts", restitution=material_of.restitution, subcycles=100)
    O.engines = [ForceResetter(), coupling, NewtonIntegrator(damping=0, gravity=(0, 0, 0))]
    O.dt = fem_dt / 100
    return fem, coupling, material


def surface_plane(coupling):
    """A node and the unit normal of triangle 0, under the sphere, at the nodal positions the next step's contacts see."""
    a, b, c = (coupling.nodePositions[k] for k in coupling.triangles[0])
    normal = (b - a).cross(c - b)
    return a, normal / normal.norm()


fem, coupling, material = surface_run(CYCLE_DT * 100, granite(True))
sphere = O.bodies.append(utils.sphere((0.13, 0.06, RADIUS + 0.5 * CYCLE_STEP), RADIUS, material=material, fixed=True))
O.bodies[sphere].state.vel = (0, 0, -CYCLE_SPEED)
coupling.connect()


def surface_step():
    # The surface placed by the last step is the one this step's contacts see; the sphere moves after them.
    node, normal = surface_plane(coupling)
    overlap = RADIUS - (O.bodies[sphere].state.pos - node).dot(normal)
    O.step()
    return (overlap, O.forces.f(sphere).dot(normal)) if overlap > 0 else None


recorder = run_cycle(sphere, surface_step)
coupling.finalize()
fem.wait(10)
recorder.report("FE surface")
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")

fem, coupling, material = surface_run(IMPACT_DT * 100, granite(False))
sphere = O.bodies.append(utils.sphere((0.13, 0.06, RADIUS + 1e-7), RADIUS, material=material))
O.bodies[sphere].state.vel = (0, 0, -IMPACT_SPEED)
coupling.connect()
touched = False
for _ in range(20000):
    O.step()
    touched = touched or coupling.surfaceContacts > 0
    if touched and O.bodies[sphere].state.pos[2] > RADIUS + 1e-7:
        break
coupling.finalize()
fem.wait(10)
report_restitution("FE surface", O.bodies[sphere].state.vel[2])
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")



# --- path 3: a polyhedral stone of PolyhedraGpuEngine on the coupled surface (contactModel='polyhedra') --------------
# The engine's restitution (0.3) is that of FrictMat materials only: the BallastMat stone and surface bring their own.
POINT = 1e-7  # [m] a tetrahedron this small dilated by R is the sphere of radius R to 1e-5 of R
TETRA = [Vector3(0, 0, -POINT), Vector3(0.943 * POINT, 0, POINT / 3), Vector3(-0.471 * POINT, 0.816 * POINT, POINT / 3),
         Vector3(-0.471 * POINT, -0.816 * POINT, POINT / 3)]


def polyhedra_run(dt, subcycles, material_of, speed):
    fem_dt = dt * subcycles
    O.reset()
    endpoint = f"ipc:///tmp/railcosim-check-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"
    fem = subprocess.Popen([dummy_fem, "--endpoint", endpoint, "--nx", "2", "--ny", "2", "--spacing", "0.2",
                            "--dt", str(fem_dt), "--mass", "1e10", "--stiffness", "1e16", "--timeout", "30"])
    material = O.materials.append(material_of)
    stone = O.bodies.append(utils.sphere((0.13, 0.06, RADIUS + POINT + 1e-7), RADIUS, material=material))
    O.bodies[stone].state.vel = (0, 0, -speed)
    engine = PolyhedraGpuEngine(dilationRadius=RADIUS, restitution=0.3, gravity=(0, 0, 0), backend="cpu")
    engine.addStone(stone, TETRA)
    coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[material], timeout=30,
                                 contactModel="polyhedra", restitution=material_of.restitution, subcycles=subcycles)
    O.engines = [coupling, engine]
    O.dt = dt
    coupling.connect()
    return fem, coupling, engine, stone


# The free stone's loading half-contact lasts ~2e-4 s: windows of 50 steps of 1e-8 s sample it some 400 times.
fem, coupling, engine, stone = polyhedra_run(1e-8, 50, granite(True), CYCLE_SPEED)
loading = []  # (overlap, normal force) at the last evaluation of each window while the stone still approaches
for _ in range(2000):
    run_steps(50)
    contacts = engine.contacts()
    if contacts and O.bodies[stone].state.vel[2] < 0:
        loading.append((contacts[0]["overlap"], contacts[0]["force"].dot(contacts[0]["normal"])))
    elif loading:
        break
coupling.finalize()
fem.wait(10)
worst = max((abs(force / virgin_force(overlap) - 1) for overlap, force in loading), default=1.0)
check(len(loading) >= 3 and worst < PEAK_FORCE_TOLERANCE,
      f"polyhedra: {len(loading)} loading samples up to {max(f for _, f in loading) if loading else 0:.4f} N on the "
      f"virgin curve (largest rel. error {worst:.1e} < {PEAK_FORCE_TOLERANCE})")
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")

fem, coupling, engine, stone = polyhedra_run(IMPACT_DT, 100, granite(False), IMPACT_SPEED)
touched = False
for _ in range(200):
    run_steps(100)
    touched = touched or len(engine.contacts()) > 0
    if touched and not engine.contacts():
        break
coupling.finalize()
fem.wait(10)
report_restitution("polyhedra", O.bodies[stone].state.vel[2])
check(fem.returncode == 0, f"stand-in FEM exited cleanly (code {fem.returncode})")

print("contact_law_paths:", "FAILED" if failures else "passed", flush=True)
sys.exit(1 if failures else 0)
