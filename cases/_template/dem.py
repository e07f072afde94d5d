# DEM participant of the template case: a few balls dropped on the coupled top face of the FEM block.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math

from railcosim.dem import CoupledDem, hertz_mindlin_contacts

GRAVITY = 9.81

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
L, W, H, R = p["block_length"], p["block_width"], p["block_height"], p["sphere_radius"]

# 1. Materials: the balls', and the block surface's (its elasticity is FreeFEM's; this sets the contact).
ball_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                       frictionAngle=math.atan(p["friction"])))
surface_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["block_density"],
                                          frictionAngle=math.atan(p["friction"])))

# 2. A grid of balls over the top face, drop_height above it.
nx, ny = p["spheres_x"], p["spheres_y"]
balls = [O.bodies.append(utils.sphere(((i + 0.5) * L / nx, (j + 0.5) * W / ny, H + R + p["drop_height"]), R,
                                      material=ball_mat))
         for i in range(nx) for j in range(ny)]
mass = sum(O.bodies[b].state.mass for b in balls)

# 3. Engines: Hertz-Mindlin contacts damped by the restitution coefficient (Thornton 2013); the coupling
#    engine after the contact loop and before the integrator.
coupling = dem.coupling_engine(material=O.materials[surface_mat], restitution=p["restitution"])
O.engines = hertz_mindlin_contacts(p["restitution"]) + [
    coupling,
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -GRAVITY)),
]
O.dt = dem.time_step()
dem.connect()  # receives the block's top surface, inserts its facets, sets O.dt = fem_dt / subcycles
print(f"{len(balls)} balls, {mass:.3f} kg ({mass * GRAVITY:.2f} N)", flush=True)


# 4. Run the windows, one record per window: the force on the block and the balls' kinetic energy.
def record():
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy())


dem.run(record, progress=lambda last: f"force on the block {-last['interface_force'][2]:.3f} N "
                                      f"(weight {mass * GRAVITY:.3f} N)")
# 5. What the post-processing reads (dem_info.json): the balls and their final state.
dem.save(particles=len(balls), particle_mass_kg=mass, final_kinetic_energy_j=utils.kineticEnergy())
