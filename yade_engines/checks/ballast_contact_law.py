# YADE check of BallastMat/BallastPhys/Law2_ScGeom_BallastPhys_Ballast: restitution, plastic overlap, save/load.
# Run: ./railcosim yade yade_engines/checks/ballast_contact_law.py   (a few seconds; exit status 0 when all pass)
# Oracles: the requested restitution (within 2 %, as the kernel test); the closed-form elasto-plastic
# Pohrt–Popov overlap δ_p = δ_max − (3F_max/(4E*√R*))^{2/3} and Table 1 of Tolomeo & McDowell (2022).
import math
import os
import sys
import tempfile

from yade import O, utils

failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message)
    if not condition:
        failures.append(message)


def engines():
    return [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_BallastMat_BallastMat_BallastPhys()],
                        [Law2_ScGeom_BallastPhys_Ballast()]),
        NewtonIntegrator(damping=0, gravity=(0, 0, 0)),
    ]


# 1. Head-on impact of two equal spheres: rebound speed / approach speed = BallastMat.restitution.
for restitution in (0.2, 0.5, 0.8):
    O.reset()
    material = O.materials.append(BallastMat(young=1e8, poisson=0.3, density=2600, frictionAngle=0.5,
                                             restitution=restitution))
    radius = 0.01
    a = O.bodies.append(utils.sphere((0, 0, 0), radius, material=material))
    b = O.bodies.append(utils.sphere((2 * radius + 1e-4, 0, 0), radius, material=material))
    O.bodies[a].state.vel = (0.5, 0, 0)
    O.bodies[b].state.vel = (-0.5, 0, 0)
    O.engines = engines()
    # Hertz contact time t_c = 2.868 (m*²/(R* E*² v))^{1/5}; 2000 steps per impact as in the kernel test.
    mass = O.bodies[a].state.mass
    e_star = 1e8 / (2 * (1 - 0.3 ** 2))
    contact_time = 2.868 * ((mass / 2) ** 2 / (radius / 2 * e_star ** 2 * 1.0)) ** 0.2
    O.dt = contact_time / 2000
    O.run(6000, True)
    achieved = (O.bodies[b].state.vel[0] - O.bodies[a].state.vel[0]) / 1.0
    check(abs(achieved / restitution - 1) < 0.02, f"restitution {restitution}: achieved {achieved:.4f} (2 % limit)")

# 2. Quasi-static load–unload of a rough elasto-plastic contact (Table 1 grains, R* = 2.36 mm) with
#    prescribed motion: plastic overlap after unloading from F_max = 500 N matches the closed form.
O.reset()
granite = O.materials.append(BallastMat(young=60e9, poisson=0.25, density=2650, frictionAngle=math.atan(0.7),
                                        restitution=1.0, roughnessFractalDim=2.13, roughnessRms=2.61e-5,
                                        plasticUnloading=True))
radius = 4.72e-3
a = O.bodies.append(utils.sphere((0, 0, 0), radius, material=granite, fixed=True))
b = O.bodies.append(utils.sphere((2 * radius, 0, 0), radius, material=granite, fixed=True))
O.engines = engines()
O.dt = 1e-6
speed = 0.01  # [m/s] → 1e-8 m per step: 7500 steps to the 500 N overlap
O.bodies[b].state.vel = (-speed, 0, 0)
peak_force = 0.0
while peak_force < 500.0:
    O.step()
    interaction = O.interactions[a, b] if O.interactions.has(a, b) else None
    if interaction is not None and interaction.isReal:
        peak_force = interaction.phys.normalForce.norm()
phys = O.interactions[a, b].phys
peak_overlap = O.interactions[a, b].geom.penetrationDepth
e_star = 60e9 / (2 * (1 - 0.25 ** 2))
r_star = radius / 2
expected_plastic = peak_overlap - (3 * phys.maxNormalForce / (4 * e_star * math.sqrt(r_star))) ** (2.0 / 3.0)
check(phys.normalModel == 2, "rough + plasticUnloading selects the elasto-plastic Pohrt–Popov law")
check(abs(phys.plasticOverlap / expected_plastic - 1) < 1e-6,
      f"plastic overlap {phys.plasticOverlap:.4e} m = closed form {expected_plastic:.4e} m")
# Unloading table derived from Tolomeo & McDowell 2022 eq. 6: F_max = 500 N → δ_p = 3.60e-5 m (3 digits; we stop just above 500 N).
check(abs(phys.plasticOverlap / 3.60e-5 - 1) < 0.01, f"plastic overlap near 3.60e-5 m at 500 N ({phys.plasticOverlap:.4e})")
O.bodies[b].state.vel = (speed, 0, 0)
zero_force_overlap = None
while O.interactions.has(a, b) and O.interactions[a, b].isReal:
    O.step()
    if not (O.interactions.has(a, b) and O.interactions[a, b].isReal):
        break
    i = O.interactions[a, b]
    if zero_force_overlap is None and i.phys.normalForce.norm() == 0.0:
        zero_force_overlap = i.geom.penetrationDepth
check(zero_force_overlap is not None and abs(zero_force_overlap - expected_plastic) < 2e-8,
      f"force vanishes at the plastic overlap (one step = 1e-8 m): {zero_force_overlap} vs {expected_plastic:.4e}")

# 3. Materials and contact history survive O.save / O.load.
O.reset()
material = O.materials.append(BallastMat(young=1e8, poisson=0.3, density=2600, restitution=0.3, rollingFriction=0.2,
                                         frictionExponent=-0.15, maxContactStress=5.17e6, label="ballast"))
a = O.bodies.append(utils.sphere((0, 0, 0), 0.01, material=material))
b = O.bodies.append(utils.sphere((0.0199, 0, 0), 0.01, material=material))
O.engines = engines()
O.dt = 1e-6
O.run(2, True)
before = O.interactions[a, b].phys.rollingArm
path = os.path.join(tempfile.mkdtemp(), "ballast.yade.gz")
O.save(path)
O.load(path)
check(O.materials["ballast"].restitution == 0.3 and O.materials["ballast"].maxContactStress == 5.17e6,
      "BallastMat attributes survive save/load")
check(abs(O.interactions[a, b].phys.rollingArm - before) < 1e-15 and abs(before - 0.2 * 0.005) < 1e-12,
      f"BallastPhys.rollingArm = η_r R1R2/(R1+R2) = 1e-3 m survives save/load ({before})")

# 4. Ip2.fixedEffectiveRadius: every contact takes the given R*. Two fixed 10 mm spheres (R1R2/(R1+R2) = 5 mm) pressed
#    1e-5 m together, smooth Hertz: F = 4/3 E* √R* δ^{3/2} with R* = 2.36 mm, the same to roundoff.
for fixed, r_star in ((0.0, 5e-3), (2.36e-3, 2.36e-3)):
    O.reset()
    smooth = O.materials.append(BallastMat(young=60e9, poisson=0.25, density=2650, frictionAngle=0.5,
                                           restitution=1.0))
    a = O.bodies.append(utils.sphere((0, 0, 0), 0.01, material=smooth, fixed=True))
    b = O.bodies.append(utils.sphere((0.02 - 1e-5, 0, 0), 0.01, material=smooth, fixed=True))
    O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                                 [Ip2_BallastMat_BallastMat_BallastPhys(fixedEffectiveRadius=fixed)],
                                 [Law2_ScGeom_BallastPhys_Ballast()]),
                 NewtonIntegrator(damping=0, gravity=(0, 0, 0))]
    O.dt = 1e-7
    O.step()
    phys = O.interactions[a, b].phys
    overlap = O.interactions[a, b].geom.penetrationDepth
    hertz = 4.0 / 3.0 * 60e9 / (2 * (1 - 0.25 ** 2)) * math.sqrt(r_star) * overlap ** 1.5
    check(abs(phys.effectiveRadius / r_star - 1) < 1e-12 and abs(phys.normalForce.norm() / hertz - 1) < 1e-9,
          f"fixedEffectiveRadius {fixed}: R* {phys.effectiveRadius:.4e} m, F {phys.normalForce.norm():.2f} N = "
          f"Hertz {hertz:.2f} N")

# 5. Invalid input is refused when the material is made, with the attribute named.
try:
    Ip2_BallastMat_BallastMat_BallastPhys(fixedEffectiveRadius=-1e-3)
    check(False, "fixedEffectiveRadius -1e-3 must be refused")
except Exception as error:
    check("fixedEffectiveRadius" in str(error), f"fixedEffectiveRadius -1e-3 refused: {error}")
try:
    BallastMat(restitution=1.5)
    check(False, "restitution 1.5 must be refused")
except Exception as error:
    check("restitution" in str(error), f"restitution 1.5 refused: {error}")

print("FAILURES:", len(failures))
sys.exit(1 if failures else 0)
