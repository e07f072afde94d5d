# DEM participant of the angle-of-repose case on the polyhedra library through its C interface
# (railcosim.polyhedra_driver), without YADE: the GPU machine's path. Two kinds of stones:
# - particle_shape = "polyhedron": the shape library's stones as dilated polyhedra (each hull's core shrunk and rounded
#   by r_d = dilation_fraction x sieve size so that its volume stays), drawn as the clusters are (sampleBallastStones:
#   shape, sieve size, turn), from the same seed; no rolling friction (T2: shape alone);
# - particle_shape = "sphere" with dem_driver = "standalone": dem.py's spheres (the same draw of diameters, from the same
#   seed) as one-point cores dilated by their radius, with the library's bounded rolling friction (η_r rolling_friction
#   between spheres, floor_rolling_friction against the floor, the pair taking the larger).
# Hertz contacts of the dilation's curvature, Mindlin friction. The rig is dem.py's (rig.py: the same hopper, lattice
# and floor); with hopper_gate_s > 0 the stones settle in the hopper on a sliding gate first. Differences from dem.py:
# no fixed base (the library has no fixed bodies: base_radius must be 0), a polyhedron's rotational kinetic energy
# from the undilated hull's principal inertia, the floor's reaction from the library's mean force over each step
# batch, the rotation integrated by Zhao-van Wachem (dem.py's spheres: YADE's leapfrog).
# Run by `railcosim run` as: python3 polyhedra_dem.py PARAMETERS.json ENDPOINT OUTDIR (DEM-only: no endpoint used)
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path[:0] = [HERE, os.path.join(ROOT, "python"), os.path.join(ROOT, "yade_engines", "clusters")]
import ballast_clusters  # noqa: E402
from railcosim import dem as dem_arguments  # noqa: E402  (YADE-free: the participant's arguments)
from railcosim import polyhedra_driver, results  # noqa: E402
from rig import Hopper, sphere_diameters  # noqa: E402

GRAVITY = 9.81
FLOOR_HALF = 5.0  # m, half the side of the floor's square: the piles of this case spread over less than 1.5 m

p, _, out = dem_arguments.participant_arguments()
rng = np.random.default_rng(p["seed"])
hopper = Hopper(p)
r = p["dilation_fraction"]
spheres = p["particle_shape"] == "sphere"

# 1. Materials (Irazábal 2017 Tables 6.1, 6.2): ballast and floor share E and ν; μ between stones and against the floor
#    (the law takes the smaller μ of a pair), a frictionless hopper (§6.2.1); rolling friction on spheres only.
young, poisson, restitution = p["particle_young"], p["particle_poisson"], p["restitution"]
stone_material = (young, poisson, restitution, p["friction"])
wall_materials = [(young, poisson, restitution, p["floor_friction"]), (young, poisson, restitution, 0.0)]

# 2. Stones: the clusters' draw (shape, sieve size, turn) until the stones' solid volume reaches the mass; each the
#    library's hull at its sieve size, its core shrunk about the centroid (the origin of the library's principal axes)
#    and dilated by r_d = r x size so that the dilated stone has the hull's volume (Steiner's formula, exact): the
#    hull's mass, its extents from 5 % below the hull's to 0.2 % above (r = 0.03).
density = p["particle_density"]
if spheres:
    # dem.py's draw (rig.sphere_diameters, the same seed): a point core dilated by the radius is the sphere
    sizes = sphere_diameters(p, rng, density)
    dilations = 0.5 * sizes
    cores = [np.zeros((1, 3)) for _ in sizes]
    orientations = [(1.0, 0.0, 0.0, 0.0)] * len(sizes)
    inertia = None  # 2/5 m r^2 from the library's masses, once the stones are in (below)
else:
    try:
        drawn = ballast_clusters.sampleDilatedStones(ballast_clusters.loadShapeLibrary(), rng,
                                                     p["ballast_mass_kg"] / density, r, density)
    except ValueError as error:
        raise SystemExit(f"polyhedra_dem.py: {error}")
    sizes, cores, dilations = drawn["sizes"], drawn["cores"], drawn["dilations"]
    orientations, inertia = drawn["orientations"], drawn["inertia"]
reaches = np.array([np.linalg.norm(c, axis=1).max() + d for c, d in zip(cores, dilations)])
centres, bin_top, _ = hopper.lattice(reaches, rng)


# 3. The bed: stones, then the floor (two triangles, z = 0) and the hopper's walls (rig.py's quadrilaterals, two
#    triangles each, counter-clockwise seen from the stones).
# Neighbour lists: a skin of 5 % of the mean size (about 2 mm; the lists are rebuilt adaptively, as stones move);
# 64 candidates, since a 22 mm stone among 63 mm ones has many within its reach plus skin (24 overflowed at 60 kg).
bed = polyhedra_driver.PolyhedraBed(p["polyhedron_dt"], stone_material, gravity=(0.0, 0.0, -GRAVITY), max_neighbours=64,
                                    neighbour_skin=0.05 * float(np.mean(sizes)), backend=p["polyhedra_backend"])
if spheres:
    # BROF (Irazábal 2017 §5.2.1): η_r between spheres; against the floor its own, the frictionless hopper none (the
    # pair takes the larger: the spheres' η_r on the hopper too, as in dem.py)
    bed.set_rolling_friction(p["rolling_friction"], [p["floor_rolling_friction"], 0.0])
for core, dilation, centre, orientation in zip(cores, dilations, centres, orientations):
    bed.add_stone(core, dilation, density, centre, orientation)
F = FLOOR_HALF
triangles = [[(-F, -F, 0), (F, -F, 0), (F, F, 0)], [(-F, -F, 0), (F, F, 0), (-F, F, 0)]]
for q in hopper.walls(bin_top):
    # rig.py's quadrilaterals wind counter-clockwise seen from outside the hopper: reversed, seen from the stones
    triangles += [[q[0], q[2], q[1]], [q[0], q[3], q[2]]]
FLOOR = [0, 1]
GATE, gate_travel = [], 0.0
if p["hopper_gate_s"] > 0.0:
    # the stones first settle in the closed hopper, then the gate slides out at hopper_gate_speed (rig.py)
    plate, gate_travel = hopper.gate()
    GATE = [len(triangles), len(triangles) + 1]
    triangles += plate
bed.set_walls(np.array(triangles, float), [0, 0] + [1] * (len(triangles) - 2), wall_materials)
bed.initialize()
impact = math.sqrt(2.0 * GRAVITY * bin_top)  # the fastest landing: from the lattice's top to the floor
critical = bed.critical_time_step(impact_velocity=impact)
if p["polyhedron_dt"] > 0.5 * critical:
    raise SystemExit(f"polyhedra_dem.py: polyhedron_dt = {p['polyhedron_dt']:g} s is above half the contacts' critical "
                     f"step {critical:.3g} s at the {impact:.2f} m/s impact (E = {young:g} Pa): take at most "
                     f"{0.5 * critical:.3g} s")
_, _, _, _, masses = bed.states()
total_mass = float(masses.sum())
if spheres:
    inertia = np.outer(0.4 * masses * dilations ** 2, np.ones(3))
backend, reason = bed.backend
kind = f"spheres (η_r {p['rolling_friction']:g})" if spheres else f"polyhedra (r_d {r:g} x size)"
print(f"{len(sizes)} {kind}, {total_mass:.2f} kg, lattice up to {bin_top:.3f} m; "
      f"dt {bed.dt:.3g} s (critical {critical:.3g} s at {impact:.2f} m/s); {backend} ({reason})", flush=True)


# 4. Discharge and rest, as dem.py: spans of rest_check_s until the hopper is empty and every stone is slower than
#    rest_speed, or duration_s; a record every record_every_s. The floor's impulse is summed from the library's mean
#    force over each batch of steps (every batch, from the start: no per-step Python call is needed).
def energies():
    pos, q, v, w, m = bed.states()
    spin = np.einsum("nji,nj->ni", ballast_clusters.rotationFromQuaternions(q), w)  # body (principal) axes: R^T w
    kinetic = 0.5 * float(np.sum(m * np.sum(v * v, axis=1)) + np.sum(inertia * spin * spin))
    return pos, v, m, kinetic, GRAVITY * float(np.sum(m * pos[:, 2]))


recorder = results.DemRecorder(out)
floor_impulse = 0.0
steps_per_record = max(1, int(round(p["record_every_s"] / bed.dt)))
_, _, _, _, initial_energy = energies()
start, steps, last_print = time.monotonic(), 0, -1.0
gate = {"moving": False, "stop": 0.0}


def span(seconds):
    """Runs `seconds` of simulated time in records of record_every_s (the last ones may end past it by less than a
    record); the gate opens, and stops once clear of the aperture, at the first record boundary at or after its time."""
    global floor_impulse, steps, last_print
    for _ in range(max(1, int(round(seconds / p["record_every_s"])))):
        if GATE and not gate["moving"] and bed.time >= p["hopper_gate_s"] - 0.5 * bed.dt:
            bed.set_wall_velocity(GATE, (p["hopper_gate_speed"], 0.0, 0.0))
            gate.update(moving=True, stop=bed.time + gate_travel / p["hopper_gate_speed"])
            print(f"gate opens at t = {bed.time:.3f} s", flush=True)
        elif gate["moving"] and gate["stop"] > 0.0 and bed.time >= gate["stop"] - 0.5 * bed.dt:
            bed.set_wall_velocity(GATE, (0.0, 0.0, 0.0))  # clear of the aperture: it stays there
            gate["stop"] = 0.0
        bed.step(steps_per_record)
        steps += steps_per_record
        # the floor's reaction on the stones: minus their force on it, a mean over the batch
        reaction = -float(bed.wall_force(FLOOR)[2])
        floor_impulse += reaction * steps_per_record * bed.dt
        pos, v, m, kinetic, potential = energies()
        recorder.append(time=bed.time, kinetic_energy=kinetic, potential_energy=potential, left_energy=0.0,
                        left_mass=0.0, hopper_mass=float(m[pos[:, 2] > hopper.z0].sum()),
                        max_speed=float(np.linalg.norm(v, axis=1).max()), floor_force=reaction,
                        floor_impulse=floor_impulse)
    last, elapsed = recorder.last, time.monotonic() - start
    if elapsed - last_print > 10.0 or bed.time >= p["duration_s"] - 0.5 * bed.dt:
        print(f"t={bed.time:.4f} s  step {steps}  hopper {last['hopper_mass']:.1f} kg  max speed "
              f"{last['max_speed']:.3f} m/s  floor {last['floor_force'] / (total_mass * GRAVITY):.3f} W  "
              f"{elapsed:.1f} s", flush=True)
        last_print = elapsed
    return last


def resting(last):
    return last["hopper_mass"] == 0.0 and last["max_speed"] < p["rest_speed"]


# At rest once two span ends in a row are: a rocking stone can pass below rest_speed at one record and move again.
# The second span is also the window of the floor's mean reaction (case.py), as in dem.py.
at_rest = False
while bed.time < p["duration_s"] - 0.5 * bed.dt:
    if resting(span(min(p["rest_check_s"], p["duration_s"] - bed.time))):
        resting_from = bed.time
        if resting(span(p["rest_check_s"])):
            print(f"at rest at t = {resting_from:.3f} s", flush=True)
            at_rest = True
            break
if not at_rest:
    at_rest = resting(span(p["rest_check_s"]))  # duration_s reached: one more span for the floor's mean reaction
wall_time = time.monotonic() - start

# 5. The pile's surface for case.py's profile fit: every stone's core vertices in the world with the dilation's radius
#    (a vertex's ball top is the stone's highest point near it).
pos, q, _, _, _ = bed.states()
R = ballast_clusters.rotationFromQuaternions(q)
points = np.concatenate([np.column_stack([pos[k] + core @ R[k].T, np.full(len(core), dilations[k])])
                         for k, core in enumerate(cores)])
info = {"steps": steps, "dt": bed.dt, "wall_time_s": wall_time, "particles": len(sizes),
        "spheres": len(sizes) if spheres else 0,
        "surface_points": len(points),
        "ballast_mass_kg": total_mass, "simulated_s": bed.time, "material": p["material"], "left_particles": 0,
        "left_mass_kg": 0.0, "base_spheres": 0, "base_top_m": 0.0, "initial_energy_j": initial_energy,
        "at_rest": at_rest, "mean_diameter_m": float(np.mean(sizes)),
        "polyhedra_backend": backend, "critical_dt": critical}
results.save_dem_outputs(out, recorder, info, spheres=points, particle_centres=pos, particle_masses=masses)
print(f"done: {steps} steps in {wall_time:.1f} s ({backend})", flush=True)
