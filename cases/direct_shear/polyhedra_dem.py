# DEM participant of the direct shear case on the polyhedra library through its C interface
# (railcosim.polyhedra_driver), without YADE (dem_driver = "standalone"): the GPU machine's path, where the
# laboratory's stone sizes fit. The test is dem.py's: the same box, grading, void ratio, materials, deposition, load,
# rest and shear, the same records and dem_info.json, so that case.py post-processes both alike. What differs:
# - the stones are the shape library's hulls as dilated polyhedra (ballast_clusters.sampleDilatedStones: core shrunk,
#   dilated by dilation_fraction x sieve size, the hull's volume kept), drawn as the clusters are (shape, sieve size,
#   turn) from the same seed; the solid volume of the void ratio is the hulls'. Hertz contacts of the dilation's
#   curvature, Mindlin friction, constant mu (the library has no stress-dependent friction);
# - the box is triangle walls (shear_box.dimensions: the same halves, end walls with the ledges that cover the gaps);
# - the plate is a wall whose vertical motion this script integrates: every PLATE_CHUNK steps its velocity changes
#   by (F - load) / m over the chunk, F the ballast's mean force on it over the chunk (dem.py: a free body of YADE's
#   integrator, blocked in x, y and rotation);
# - forces are means over each batch of steps (dem.py: samples_per_record samples a record);
# - the library's numerical damping (YADE's non-viscous damping) acts on the stones' translation only;
# - each phase with other materials (deposition, test) is a new bed: contacts start anew from the stones' states;
# - one step for deposition and test, polyhedron_dt (the thesis's 2.5 µs): 5 µs, below half the contacts' critical
#   step at the impacts, ran past the neighbour lists once stones locked across the shear plane (README).
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
import shear_box  # noqa: E402
from railcosim import bedcache, polyhedra_driver, results  # noqa: E402
from railcosim import dem as dem_arguments  # noqa: E402  (YADE-free: the participant's arguments)
from railcosim.polyhedra_driver import assemble_walls, rectangle  # noqa: E402

GRAVITY = 9.81
PLATE_CHUNK = 10        # steps between the plate's velocity updates: 25 µs at 2.5 µs, against the plate's period on the
                        # sample (2 pi sqrt(m/k), k ~ E_sample A / h ~ 2e7 N/m: about 10 ms)
PLATE_CLEARANCE = 1e-3  # m between the plate's edges and the walls (dem.py's)
MAX_NEIGHBOURS = 64     # candidates a stone: a small stone among large ones has many (cases/angle_of_repose)
MAX_WALL_NEIGHBOURS = 16  # triangles a stone may touch at once: in a corner, floor, two walls and a ledge, two each
SAMPLE_PROCEDURE = 2    # part of the sample's cache key: raised whenever the deposition changes

p, _, out = dem_arguments.participant_arguments()
wall_start = time.monotonic()
stresses, sieves, passing = shear_box.settings(p)
L, B, H, split, t, solid_volume = shear_box.dimensions(p)
rng = np.random.default_rng(p["seed"])
density = p["ballast_density"]

# 1. Materials (Table 6.3; the library's pair takes the smaller mu). Deposition (§6.3.2): ballast mu0, frictionless
#    walls. Test: walls and plate mu 0.6 (steel), ballast mu0. E is polyhedron_young for stones and walls: a contact's
#    Hertz curvature is the dilation (3 % of the size), not a member sphere's (a quarter), and at the clusters' 0.24 GPa
#    the plate's load pushes a corner's overlap past its dilation (the cores meet).
e = p["restitution"]
young = p["polyhedron_young"]
stone_material = (young, p["ballast_poisson"], e, p["ballast_friction"])
fill_wall = (young, p["ballast_poisson"], e, 0.0)
test_wall = (young, p["ballast_poisson"], e, p["wall_friction"])

# 2. Stones: the hulls of the clusters' draw until the solid volume of the void ratio is reached.
try:
    stones = ballast_clusters.sampleDilatedStones(ballast_clusters.loadShapeLibrary(), rng, solid_volume,
                                                  p["dilation_fraction"], density, targetPassing=passing, sieves=sieves)
except ValueError as error:
    raise SystemExit(f"polyhedra_dem.py: {error}")
cores, dilations, reaches, inertia = stones["cores"], stones["dilations"], stones["reaches"], stones["inertia"]
count = len(cores)


# 3. The box (shear_box.dimensions): the lower half (floor, end walls with the ledge over the x = 0 one, side walls)
#    moves along x; the upper half (end walls with the ledge under the x = L one, side walls) is fixed; the plate
#    faces down. Every wall reaches t beyond the inside; each triangle faces the stones.
def box_walls(top, plate_z=None):
    w, s = B + 2 * t, split + t
    parts = {"lower": (rectangle((-t, -t, 0.0), (L + 2 * t, 0, 0), (0, w, 0)) +          # floor, facing +z
                       rectangle((0.0, -t, -t), (0, w, 0), (0, 0, s)) +                   # x = 0, facing +x
                       rectangle((-t, -t, split), (t, 0, 0), (0, w, 0)) +                 # its top ledge, +z
                       rectangle((L, -t, -t), (0, 0, s), (0, w, 0)) +                     # x = L, facing -x
                       rectangle((-t, 0.0, -t), (0, 0, s), (L + 2 * t, 0, 0)) +           # y = 0, facing +y
                       rectangle((-t, B, -t), (L + 2 * t, 0, 0), (0, 0, s))),             # y = B, facing -y
             "upper": (rectangle((0.0, -t, split), (0, w, 0), (0, 0, top - split)) +      # x = 0, facing +x
                       rectangle((L, -t, split), (0, 0, top - split), (0, w, 0)) +        # x = L, facing -x
                       rectangle((L, -t, split), (0, w, 0), (t, 0, 0)) +                  # its bottom ledge, -z
                       rectangle((-t, 0.0, split), (0, 0, top - split), (L + 2 * t, 0, 0)) +
                       rectangle((-t, B, split), (L + 2 * t, 0, 0), (0, 0, top - split)))}
    if plate_z is not None:
        c = PLATE_CLEARANCE
        parts["plate"] = rectangle((c, c, plate_z), (0, B - 2 * c, 0), (L - 2 * c, 0, 0))  # facing -z
    return assemble_walls(parts)


def new_bed(dt, wall, state, top, plate_z=None, damping=0.0):
    """A bed of the stones at `state` (positions, orientations, velocities, spins) in the box with the wall material
    `wall`; the library's walls are fixed once stepped, so each phase is a new bed."""
    bed = polyhedra_driver.PolyhedraBed(dt, stone_material, gravity=(0.0, 0.0, -GRAVITY), max_neighbours=MAX_NEIGHBOURS,
                                        max_wall_neighbours=MAX_WALL_NEIGHBOURS,
                                        neighbour_skin=0.05 * float(np.mean(stones["sizes"])),
                                        backend=p["polyhedra_backend"])
    for k in range(count):
        bed.add_stone(cores[k], dilations[k], density, state[0][k], state[1][k], state[2][k], state[3][k])
    corners, parts = box_walls(top, plate_z)
    bed.set_walls(corners, np.zeros(len(corners), np.int32), [wall])
    bed.initialize()
    bed.set_damping(damping)
    return bed, parts


def check_step(bed, impact, phase):
    """Refuses a step above half the contacts' critical one at the phase's fastest impact."""
    critical = bed.critical_time_step(impact_velocity=impact)
    if bed.dt > 0.5 * critical:
        raise SystemExit(f"polyhedra_dem.py: the {phase} step {bed.dt:g} s is above half the contacts' critical step "
                         f"{critical:.3g} s at {impact:.2f} m/s (E = {young:g} Pa): take at most "
                         f"{0.5 * critical:.3g} s")
    return critical


def overlap_share(bed):
    """The largest contact overlap over the dilations it may use (r_A + r_B between stones, r against a wall): at 1 the
    cores meet and the dilated contact law no longer holds (a soft E or a thin dilation under the load)."""
    c = bed.contacts()
    acting = np.any(c["force"] != 0.0, axis=1)  # a wall contact twice over (coplanar triangles) acts once
    if not np.any(acting):
        return 0.0
    first, second, wall = c["first"][acting], c["second"][acting], c["wall"][acting]
    reach = dilations[first] + np.where(wall, 0.0, dilations[np.where(wall, 0, second)])
    return float(np.max(c["overlap"][acting] / reach))


def highest_point(state):
    """z [m] of the stones' highest point: each core vertex in the world plus its stone's dilation."""
    R = ballast_clusters.rotationFromQuaternions(state[1])
    return max(float(np.max(state[0][k, 2] + cores[k] @ R[k][2])) + dilations[k] for k in range(count))


# 4. Deposition (the pre-calculation, §6.3.2): the column falls into the box, with numerical damping, until every stone
#    is slower than rest_speed (checked every 0.05 s) or fill_s; cached and reused by every stress and by runs that
#    differ only in the test's settings.
KEYS = ("box_length", "box_width", "box_height", "shear_distance", "grading_sieves_mm", "grading_passing", "size_scale",
        "void_ratio", "dilation_fraction", "polyhedron_young", "ballast_poisson", "ballast_density", "ballast_friction",
        "restitution", "polyhedron_dt", "fill_s", "rest_speed", "packing_damping", "seed")
cache = bedcache.path("direct_shear",
                      {"driver": "standalone", "procedure": SAMPLE_PROCEDURE, **{k: p[k] for k in KEYS}},
                      name="sample", fallback=os.path.join(out, "cache"))
fill_this_run, backend = 0.0, None
with bedcache.exclusive(cache) as found:
    if not found:
        try:
            centres, column_top = shear_box.place(p, reaches, rng)
        except ValueError as error:
            raise SystemExit(f"polyhedra_dem.py: {error}")
        top = column_top + 0.05
        zeros = np.zeros((count, 3))
        bed, _ = new_bed(p["polyhedron_dt"], fill_wall, (centres, stones["orientations"], zeros, zeros), top,
                         damping=p["packing_damping"])
        backend = bed.backend
        critical = check_step(bed, math.sqrt(2.0 * GRAVITY * column_top), "deposition")
        print(f"deposition: {count} polyhedra in a column up to {column_top:.3f} m; dt {bed.dt:.3g} s (critical "
              f"{critical:.3g} s); {backend[0]} ({backend[1]})", flush=True)
        start = time.monotonic()
        chunk = max(1, int(round(0.05 / bed.dt)))
        while bed.time < p["fill_s"] - 0.5 * chunk * bed.dt:
            bed.step(chunk)
            fastest = float(np.max(np.linalg.norm(bed.states()[2], axis=1)))
            if fastest < p["rest_speed"]:
                break
        if fastest >= p["rest_speed"]:
            print(f"deposition: WARNING: fill_s = {p['fill_s']:g} s ended with a stone at {fastest:.3f} m/s, above "
                  f"rest_speed; the rest under the plate settles it", flush=True)
        fill_this_run = time.monotonic() - start
        state = bed.states()
        print(f"deposition: {bed.time:.2f} s simulated, fastest stone {fastest:.3f} m/s, {fill_this_run:.0f} s",
              flush=True)
        partial = f"{cache}.{os.getpid()}.npz"
        np.savez(partial, positions=state[0], orientations=state[1], velocities=state[2], spins=state[3],
                 fill_wall_time_s=fill_this_run, column_top=top, sizes=stones["sizes"], fastest=fastest,
                 backend=backend[0])
        os.replace(partial, cache)
        bed = None
with np.load(cache) as saved:
    sample = tuple(saved[k] for k in ("positions", "orientations", "velocities", "spins"))
    fill_wall_time, top = float(saved["fill_wall_time_s"]), float(saved["column_top"])
    fill_fastest, fill_backend = float(saved["fastest"]), str(saved["backend"])
    cached_sizes = saved["sizes"]
# The cores come from the draw, the poses from the cache: a changed shape library or draw must not pair them wrongly.
if len(cached_sizes) != count or not np.array_equal(cached_sizes, stones["sizes"]):
    raise SystemExit(f"polyhedra_dem.py: the cached sample {cache} was packed from another draw of stones "
                     f"({len(cached_sizes)} stones, this draw {count}): remove it")
print(f"{count} stones as polyhedra (sieve {sieves[0]:.1f}-{sieves[-1]:.1f} mm), solid volume {solid_volume:.5f} m3; "
      f"sample {cache}", flush=True)


# 5. One shear test per normal stress from the packed sample: the test's materials, the plate brought down onto the
#    sample until it carries the load, the rest under it (numerical damping), then the lower half moves at
#    shear_velocity to shear_distance without damping.
recorder = results.DemRecorder(out)
masses = None
v = p["shear_velocity"]
tests = []
for sigma in stresses:
    area = L * B
    load = sigma * area  # the plate's weight and the added force: sigma_n over the whole box
    z0 = highest_point(sample)
    bed, parts = new_bed(p["polyhedron_dt"], test_wall, sample, max(top, z0 + 0.05), plate_z=z0 + PLATE_CLEARANCE,
                         damping=p["packing_damping"])
    backend = bed.backend
    critical = check_step(bed, p["approach_velocity"], "test")
    masses = bed.states()[4]
    plate = {"z": z0 + PLATE_CLEARANCE, "v": -p["approach_velocity"]}

    def advance(steps, free=True):
        """`steps` steps in chunks of PLATE_CHUNK, the plate free (its velocity integrated) or at its set velocity:
        the mean forces of the ballast on the walls over them {part: (3)}."""
        done, sums = 0, {name: np.zeros(3) for name in parts}
        while done < steps:
            n = min(PLATE_CHUNK, steps - done)
            bed.set_wall_velocity(parts["plate"], (0.0, 0.0, plate["v"]))
            try:
                bed.step(n)
            except polyhedra_driver.DriverError as error:
                raise SystemExit(f"polyhedra_dem.py: at t = {bed.time:.4f} s under {sigma / 1e3:g} kPa: {error}. "
                                 f"A stone moved too far in a step: lower polyhedron_dt ({bed.dt:g} s)") from None
            plate["z"] += plate["v"] * n * bed.dt
            forces = {name: bed.wall_force(triangles) for name, triangles in parts.items()}
            for name in parts:
                sums[name] += n * forces[name]
            if not np.isfinite(forces["plate"][2]):
                raise SystemExit(f"polyhedra_dem.py: the forces are no longer finite at t = {bed.time:.4f} s under "
                                 f"{sigma / 1e3:g} kPa (largest overlap {overlap_share(bed):.2f} of the dilations): "
                                 f"the stones' cores met; raise polyhedron_young or dilation_fraction")
            if free:
                plate["v"] += (forces["plate"][2] - load) / p["plate_mass"] * n * bed.dt
            done += n
        return {name: s / steps for name, s in sums.items()}

    start = time.monotonic()
    while advance(PLATE_CHUNK, free=False)["plate"][2] < load:
        if plate["z"] < 0.25 * H:
            raise SystemExit("polyhedra_dem.py: the plate went down to a quarter of the box without meeting the sample")
    plate["v"] = 0.0
    advance(max(1, int(round(p["rest_s"] / bed.dt))))
    bed.set_damping(0.0)
    rest_wall = time.monotonic() - start
    overlap_rest = overlap_share(bed)
    h0 = plate["z"]  # the plate's face: the sample's height
    stone_volume = float(masses.sum()) / density
    void_ratio = L * B * h0 / stone_volume - 1.0
    print(f"sigma_n {sigma / 1e3:g} kPa: rested {rest_wall:.0f} s, sample height {h0 * 1e3:.1f} mm, void ratio "
          f"{void_ratio:.3f}, largest overlap {overlap_rest:.2f} of the dilations; dt {bed.dt:.3g} s (critical "
          f"{critical:.3g} s), {backend[0]}", flush=True)
    momentum_start = float(np.sum(masses * bed.states()[2][:, 0]))
    bed.set_wall_velocity(parts["lower"], (v, 0.0, 0.0))
    t0 = bed.time
    # Records of equal length (case.py takes plain means over them): the shear ends within a step of shear_distance.
    record_count = max(1, int(round(p["shear_distance"] / p["record_every_m"])))
    per_record = max(1, int(round(p["shear_distance"] / (v * bed.dt * record_count))))
    steps = per_record * record_count
    overlap = overlap_rest
    first, done, last_print = recorder.windows, 0, time.monotonic()
    start = time.monotonic()
    while done < steps:
        n = min(per_record, steps - done)
        forces = advance(n)
        done += n
        overlap = max(overlap, overlap_share(bed))
        positions, q, velocities, spins, _ = bed.states()
        u = v * (bed.time - t0)
        contact_area = B * (L - u)  # Irazábal eqs. 6.1-6.2
        normal = load + GRAVITY * float(masses[positions[:, 2] > split].sum())
        shear = float(forces["upper"][0] + forces["plate"][0])
        spin = np.einsum("nji,nj->ni", ballast_clusters.rotationFromQuaternions(q), spins)  # body axes: R^T w
        kinetic = 0.5 * float(np.sum(masses * np.sum(velocities ** 2, axis=1)) + np.sum(inertia * spin * spin))
        recorder.append(time=bed.time, shear_displacement=u, shear_force=shear,
                        lower_force_x=float(forces["lower"][0]), normal_force=normal, shear_stress=shear / contact_area,
                        normal_stress=normal / contact_area, plate_contact_force_z=float(forces["plate"][2]),
                        applied_load=load, dilation=plate["z"] - h0, kinetic_energy=kinetic,
                        momentum_x=float(np.sum(masses * velocities[:, 0])), normal_stress_applied=sigma)
        if time.monotonic() - last_print > 10.0 or done >= steps:
            last = recorder.last
            print(f"sigma_n {sigma / 1e3:g} kPa  u={1e3 * u:.1f} mm  tau={last['shear_stress'] / 1e3:.1f} kPa  "
                  f"dh={1e3 * last['dilation']:.2f} mm  {time.monotonic() - wall_start:.0f} s", flush=True)
            last_print = time.monotonic()
    tests.append({"normal_stress_Pa": sigma, "first_record": first, "momentum_x_start": momentum_start,
                  "records": recorder.windows - first, "sample_height_m": h0, "void_ratio": void_ratio,
                  "rest_wall_time_s": rest_wall, "shear_wall_time_s": time.monotonic() - start, "shear_steps": steps,
                  "spheres": 0, "friction_check": None,
                  "overlap_share": overlap, **bed.step_counters})
    bed = None  # the next stress makes its own

info = {"deposition_at_rest": fill_fastest < p["rest_speed"], "deposition_fastest_m_s": fill_fastest,
        "deposition_backend": fill_backend, "dt": p["polyhedron_dt"], "stones": count, "spheres": 0,
        "solid_volume_m3": stone_volume,
        "target_solid_volume_m3": solid_volume, "sieves_mm": list(sieves), "tests": tests,
        "fill_wall_time_s": fill_wall_time, "fill_this_run_s": fill_this_run,
        "total_wall_time_s": time.monotonic() - wall_start, "packed_sample": cache, "particles": "polyhedra",
        "dilation_fraction": p["dilation_fraction"], "polyhedra_backend": backend[0] if backend else None}
results.save_dem_outputs(out, recorder, info)
print(f"done in {info['total_wall_time_s']:.0f} s ({info['polyhedra_backend']})", flush=True)
