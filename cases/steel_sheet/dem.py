# DEM participant of the steel-sheet case: wheat (spheres) settles in a closed hopper, the flaps open at t = 0 and the
# stream falls onto the coupled top face of the FEM sheet. Run by `railcosim run` as:
# railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math

import numpy as np

from railcosim.dem import CoupledDem, hertz_mindlin_contacts

GRAVITY = 9.81

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
rng = np.random.default_rng(p["seed"])
top = p["sheet_thickness"]                      # the sheet's top face, z
xo, W = p["outlet_x"], p["hopper_width"]
z_flaps = top + p["fall_height"]                # the flaps' plane
z_slides = z_flaps + p["gap"]                   # the hand-slides' plane (the hopper's bottom)
z_flow = z_flaps - p["flow_plane_depth"]        # the plane the mass flow rate is measured at
z_park = -0.05                                  # grains below this have left the sheet: parked far away, inert

# 1. Materials (Tables 5.1, 5.2). Hertz-Mindlin takes the smaller friction angle of a pair, so the grain's own μ acts
#    between grains and the steel's or frame's against the sheet, clamp and flaps or the hopper.
grain = O.materials.append(FrictMat(young=p["grain_young"], poisson=p["grain_poisson"], density=p["grain_density"],
                                    frictionAngle=math.atan(p["friction"]), label="wheat"))
steel = O.materials.append(FrictMat(young=p["sheet_young"], poisson=p["sheet_poisson"], density=p["sheet_density"],
                                    frictionAngle=math.atan(p["steel_friction"]), label="steel"))
frame = O.materials.append(FrictMat(young=p["frame_young"], poisson=0.3, density=7800.0,
                                    frictionAngle=math.atan(p["frame_friction"]), label="frame"))
tray_mat = O.materials.append(FrictMat(young=p["frame_young"], poisson=0.3, density=7800.0, frictionAngle=0.0,
                                       label="tray"))


def quad(a, b, c, d, material):
    """Two facets of the rectangle a-b-c-d."""
    return [O.bodies.append(utils.facet((Vector3(*a), Vector3(*b), Vector3(*c)), material=material, wire=True)),
            O.bodies.append(utils.facet((Vector3(*a), Vector3(*c), Vector3(*d)), material=material, wire=True))]


# 2. The rig. The clamp (x = 0 to clamp_length) is rigid steel level with the sheet's top face. The hopper: a bin
#    x0..x1 by 0..W up to z_top, its bottom two hand-slides leaving the outlet xo -/+ outlet_length/2; below them, gap
#    deep, the flaps from xo -/+ flap_length (their hinges) to xo close the gap, whose ends are walls at the hinges.
x0, x1 = xo - 0.5 * p["hopper_length"], xo + 0.5 * p["hopper_length"]
xa, xb = xo - 0.5 * p["outlet_length"], xo + 0.5 * p["outlet_length"]
xf0, xf1 = xo - p["flap_length"], xo + p["flap_length"]
if not (x0 <= xf0 < xa and xb < xf1 <= x1):
    raise ValueError(f"the flaps' hinges {xf0:.3f}, {xf1:.3f} m must lie outside the outlet {xa:.3f}-{xb:.3f} m and within "
                     f"the hopper {x0:.3f}-{x1:.3f} m (flap_length, outlet_length, hopper_length)")
d_min, d_max = p["diameter_min"], p["diameter_max"]
# Grains: diameters uniform in [d_min, d_max] until the mass is reached, on a jittered lattice filling the bin upwards.
diameters, mass = [], 0.0
while mass < p["grain_mass_kg"]:
    diameters.append(rng.uniform(d_min, d_max))
    mass += p["grain_density"] * math.pi / 6.0 * diameters[-1] ** 3
spacing = 1.05 * d_max
nx, ny = int((x1 - x0) / spacing), int(W / spacing)
centres = []
while len(centres) < len(diameters):
    z = z_slides + 0.5 * spacing + (len(centres) // (nx * ny)) * spacing
    for i in range(nx):
        for j in range(ny):
            if len(centres) < len(diameters):
                jitter = rng.uniform(-0.02, 0.02, 2) * spacing
                centres.append((x0 + (i + 0.5) * (x1 - x0) / nx + jitter[0], (j + 0.5) * W / ny + jitter[1], z))
z_top = max(c[2] for c in centres) + spacing
grains = [O.bodies.append(utils.sphere(c, 0.5 * d, material=grain)) for c, d in zip(centres, diameters)]
masses = {i: O.bodies[i].state.mass for i in grains}
total_mass = sum(masses.values())

walls = quad((0, 0, top), (p["clamp_length"], 0, top), (p["clamp_length"], W, top), (0, W, top), steel)
walls += quad((x0, 0, z_slides), (xa, 0, z_slides), (xa, W, z_slides), (x0, W, z_slides), frame)      # hand-slides
walls += quad((xb, 0, z_slides), (x1, 0, z_slides), (x1, W, z_slides), (xb, W, z_slides), frame)
walls += quad((x0, 0, z_slides), (x0, W, z_slides), (x0, W, z_top), (x0, 0, z_top), frame)            # bin ends
walls += quad((x1, 0, z_slides), (x1, W, z_slides), (x1, W, z_top), (x1, 0, z_top), frame)
walls += quad((xf0, 0, z_flaps), (xf0, W, z_flaps), (xf0, W, z_slides), (xf0, 0, z_slides), frame)    # gap ends
walls += quad((xf1, 0, z_flaps), (xf1, W, z_flaps), (xf1, W, z_slides), (xf1, 0, z_slides), frame)
for y in (0.0, W):                                                                                     # sides
    walls += quad((x0, y, z_slides), (x1, y, z_slides), (x1, y, z_top), (x0, y, z_top), frame)
    walls += quad((xf0, y, z_flaps), (xf1, y, z_flaps), (xf1, y, z_slides), (xf0, y, z_slides), frame)
if p["tray_height"] > 0:
    # The smoke scene's tray: frictionless walls standing on the sheet's free edges keep the grains (spheres roll without
    # end on a flat sheet) so that they come to rest; vertical and frictionless, they carry none of their weight.
    L, h = p["sheet_length"], top + p["tray_height"]
    walls += quad((0, 0, top), (L, 0, top), (L, 0, h), (0, 0, h), tray_mat)
    walls += quad((0, W, top), (L, W, top), (L, W, h), (0, W, h), tray_mat)
    walls += quad((L, 0, top), (L, W, top), (L, W, h), (L, 0, h), tray_mat)
flap_left = quad((xf0, 0, z_flaps), (xo, 0, z_flaps), (xo, W, z_flaps), (xf0, W, z_flaps), steel)
flap_right = quad((xo, 0, z_flaps), (xf1, 0, z_flaps), (xf1, W, z_flaps), (xo, W, z_flaps), steel)
# The flaps swing down about their hinges (axis y) by 90° at a constant rate over flap_opening_s, then stop.
flap_rate = 0.5 * math.pi / p["flap_opening_s"]
flaps = [RotationEngine(ids=flap_left, rotationAxis=(0, 1, 0), angularVelocity=0.0, rotateAroundZero=True,
                        zeroPoint=(xf0, 0, z_flaps), label="flap_left"),
         RotationEngine(ids=flap_right, rotationAxis=(0, 1, 0), angularVelocity=0.0, rotateAroundZero=True,
                        zeroPoint=(xf1, 0, z_flaps), label="flap_right")]

# 3. Engines: Hertz-Mindlin with the restitution's viscous damping (Thornton 2013), the flaps, the coupling engine
#    after the contact loop, the integrator without numerical damping.
coupling = dem.coupling_engine(material=O.materials[steel], restitution=p["restitution"])
contact_loop = hertz_mindlin_contacts(p["restitution"])
integrator = NewtonIntegrator(damping=0.0, gravity=(0, 0, -GRAVITY))
O.dt = dem.time_step()

# 4. Settling in the closed hopper (uncoupled; the FEM waits): the grains fill the gap on the closed flaps, the seed's
#    initial reservoir.
if p["settle_s"] > 0 and not dem.resuming:
    O.engines = contact_loop + flaps + [integrator]
    O.run(max(1, int(round(p["settle_s"] / O.dt))), True)
    print(f"settled for {O.time:.3f} s: kinetic energy {utils.kineticEnergy():.3e} J", flush=True)
O.engines = contact_loop + flaps + [coupling, integrator]
dem.connect()  # receives the sheet's top surface, inserts its facets, sets O.dt = fem_dt / subcycles
print(f"{len(grains)} grains, {total_mass:.4f} kg, diameters {min(diameters) * 1e3:.2f}-{max(diameters) * 1e3:.2f} mm, "
      f"hopper {x0:.3f}-{x1:.3f} m filled to {z_top - z_slides:.3f} m", flush=True)


# 5. The windows. The flaps turn while t < flap_opening_s. Every bulk_record_s the masses are counted and the grains
#    that fell below the sheet parked, inert, far below (kept as bodies: the scene keeps its size for restart
#    checkpoints); the records in between repeat those figures. The mean nodal forces of the final span
#    (average_s) are summed in dem.state for the static FEM reference.
def park(i, k):
    s = O.bodies[i].state
    s.blockedDOFs = "xyzXYZ"
    s.vel, s.angVel = Vector3.Zero, Vector3.Zero
    s.pos = Vector3(10.0 + 2.0 * d_max * (k % 1000), 2.0 * d_max * (k // 1000), -10.0)


dem.state.update(parked=0, force_sum=None, force_windows=0, bulk={})
# The sheet's footprint less a grain radius: there a grain centre more than half the smallest radius below the lowest
# point of the deflected sheet's top face across its width (at the grain's x) has passed through the sheet.
inner = (p["clamp_length"] + 0.5 * d_max, p["sheet_length"] - 0.5 * d_max, 0.5 * d_max, p["sheet_width"] - 0.5 * d_max)
bulk_every = max(1, int(round(p["bulk_record_s"] / p["fem_dt"])))  # windows between two passes over all grains


def bulk_figures():
    """Masses above the flaps, past the flow plane, on the sheet and parked; grains through the sheet; top speed.
    Parks the grains that have fallen below the sheet's level."""
    positions = {i: O.bodies[i].state.pos for i in grains}
    nodes = np.array([tuple(v) for v in coupling.nodePositions], dtype=float)
    order = np.argsort(nodes[:, 0])
    # the grid's columns of nodes: x values more than 0.2 mm apart (the finest grid line spacing is 0.75 mm, the
    # in-plane displacements are below 0.1 mm)
    column_of = np.empty(len(nodes), dtype=int)
    column_of[order] = np.concatenate([[0], np.cumsum(np.diff(nodes[order, 0]) > 2e-4)])
    lowest = np.full(column_of.max() + 1, np.inf)
    np.minimum.at(lowest, column_of, nodes[:, 2])
    columns = np.array([nodes[column_of == c, 0].mean() for c in range(len(lowest))])
    for i in grains:
        if z_park > positions[i][2] > -1.0:
            park(i, dem.state["parked"])
            dem.state["parked"] += 1
            positions[i] = O.bodies[i].state.pos

    def over_sheet(pos):
        return p["clamp_length"] < pos[0] < p["sheet_length"] and 0.0 < pos[1] < p["sheet_width"]

    def inside(pos):
        return inner[0] < pos[0] < inner[1] and inner[2] < pos[1] < inner[3]

    return dict(passed_mass=sum(masses[i] for i in grains if positions[i][2] < z_flow),
                hopper_mass=sum(masses[i] for i in grains if positions[i][2] > z_flaps),
                sheet_mass=sum(masses[i] for i in grains if over_sheet(positions[i]) and top < positions[i][2] < top + 0.05),
                clamp_mass=sum(masses[i] for i in grains if positions[i][0] <= p["clamp_length"] and 0 < positions[i][1] < W
                               and top < positions[i][2] < top + 0.05),
                parked_mass=sum(masses[i] for i in grains if positions[i][2] < -1.0),
                through_sheet=sum(1 for i in grains if inside(positions[i]) and -1.0 < positions[i][2]
                                  < np.interp(positions[i][0], columns, lowest) - 0.25 * d_min),
                max_speed=max(O.bodies[i].state.vel.norm() for i in grains))


def record():
    t = dem.time
    speed = flap_rate if t < p["flap_opening_s"] - 0.5 * O.dt else 0.0
    flaps[0].angularVelocity, flaps[1].angularVelocity = speed, -speed
    window = int(round(t / p["fem_dt"]))
    if window % bulk_every == 0 or not dem.state["bulk"]:
        dem.state["bulk"] = bulk_figures()
    if t >= p["duration_s"] - p["average_s"] - 1e-12:
        forces = np.array([tuple(f) for f in coupling.nodalForces], dtype=float)
        dem.state["force_sum"] = forces if dem.state["force_sum"] is None else dem.state["force_sum"] + forces
        dem.state["force_windows"] += 1
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(), **dem.state["bulk"])


dem.run(record, progress=lambda last: f"hopper {last['hopper_mass']:.3f} kg  passed {last['passed_mass']:.3f} kg  "
                                      f"sheet {last['sheet_mass']:.3f} kg  Fz {-last['interface_force'][2]:.3f} N")
# 6. What the post-processing reads (dem_info.json): the grains, the rig's planes, the final span's mean nodal forces.
mean_forces = dem.state["force_sum"] / max(1, dem.state["force_windows"])
dem.save(particles=len(grains), total_grain_mass_kg=total_mass, diameter_min_m=min(diameters),
         diameter_max_m=max(diameters), flow_plane_z=z_flow, flaps_z=z_flaps, final_kinetic_energy_j=utils.kineticEnergy(),
         parked=dem.state["parked"], mean_force_windows=dem.state["force_windows"],
         arrays={"triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int),
                 "node_positions": np.array([tuple(v) for v in coupling.nodePositions], dtype=float), "mean_nodal_forces": mean_forces})
