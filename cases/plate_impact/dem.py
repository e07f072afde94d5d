# DEM participant of the plate impact: one elastic sphere strikes the coupled top face of the FEM plate.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
from railcosim.dem import CoupledDem

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
L, T, R = p["plate_length"], p["plate_thickness"], p["sphere_radius"]

# 1. Frictionless steel: the sphere exchanges only normal impulse, so its spin stays zero.
sphere_mat = O.materials.append(FrictMat(young=p["plate_young"], poisson=p["plate_poisson"],
                                         density=p["sphere_density"], frictionAngle=0.0))
plate_mat = O.materials.append(FrictMat(young=p["plate_young"], poisson=p["plate_poisson"],
                                        density=p["plate_density"], frictionAngle=0.0))
sphere = O.bodies.append(utils.sphere((L / 2, L / 2, T + R + 2e-5), R, material=sphere_mat))
O.bodies[sphere].state.vel = (0, 0, -p["impact_velocity"])

# 2. The engine finds the contact itself (contact_model = "meshContacts"); restitution 1 = no contact damping.
coupling = dem.coupling_engine(material=O.materials[plate_mat], restitution=1.0)
O.engines = [ForceResetter(), coupling, NewtonIntegrator(damping=0.0, gravity=(0, 0, 0))]
O.dt = dem.time_step()
dem.connect()
mass = O.bodies[sphere].state.mass
initial_energy = 0.5 * mass * p["impact_velocity"] ** 2
print(f"sphere {mass:.4f} kg at {p['impact_velocity']} m/s ({initial_energy:.4e} J)", flush=True)

# 3. Run the windows, one record per window: sphere velocity and energy, contact force and contacts. A count kept
#    over the run lives in dem.state, which a restart checkpoint keeps.
dem.state["contact_windows"] = 0


def record():
    s = O.bodies[sphere].state
    dem.state["contact_windows"] += int(coupling.surfaceContacts > 0)
    return dict(sphere_velocity_z=s.vel[2],
                sphere_kinetic_energy=0.5 * mass * s.vel.squaredNorm() + 0.5 * s.inertia.dot(
                    Vector3(s.angVel[0] ** 2, s.angVel[1] ** 2, s.angVel[2] ** 2)),
                interface_force_z=coupling.totalForce[2], surface_contacts=coupling.surfaceContacts)


dem.run(record, progress=lambda last: f"sphere v_z {last['sphere_velocity_z']:.4f} m/s")
# 4. What the post-processing reads (dem_info.json): the energy before and after the impact.
dem.save(particles=1, initial_energy_j=initial_energy, final_sphere_energy_j=dem.last["sphere_kinetic_energy"],
         contact_windows=dem.state["contact_windows"])
print(f"rebound {dem.last['sphere_velocity_z']:.4f} m/s, the sphere keeps "
      f"{dem.last['sphere_kinetic_energy'] / initial_energy:.2%} of its energy", flush=True)
