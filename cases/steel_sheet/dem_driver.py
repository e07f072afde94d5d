# DEM participant of the steel-sheet case without YADE (dem_driver = "standalone"): the same rig (rig.py) on the
# polyhedra library through its C interface (railcosim.polyhedra_driver), each wheat grain a sphere as a dilated
# polyhedron with a one-point core (the Hertz law of the dilation's curvature: a sphere's), one coupling window per
# call; the GPU machine's path, where YADE is not. Differences from dem.py (README "On the GPU machine"): grains that
# leave the sheet fall into a catch tray 0.3 m below it instead of being parked (the library has no inert bodies), the
# settled reservoir starts the coupled run without the settling's tangential contact history, the kinetic energy is
# recorded with the masses every bulk_record_s.
# Run by `railcosim run` as: python3 dem_driver.py PARAMETERS.json ENDPOINT OUTDIR
# With `--checkpoint-every S` the driver saves a restart checkpoint with the FEM side every S s of simulated time;
# `--resume OUT` goes on from the newest one.
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(os.path.dirname(HERE)), "python")]
from railcosim import dem as coupled_dem  # noqa: E402  (coupling options; YADE-free)
from railcosim import polyhedra_driver, results, solvers  # noqa: E402
from rig import GRAVITY, Rig  # noqa: E402

p, endpoint, out = coupled_dem.participant_arguments()
rng = np.random.default_rng(p["seed"])
rig = Rig(p)
diameters, centres = rig.grains(rng)
POINT = np.zeros((1, 3))  # a sphere: the one-point core dilated by its radius
# The catch tray (standalone only): a floor CATCH_DEPTH under the sheet with walls CATCH_WALL high, wide enough for what
# leaves the sheet's free end and sides; dem.py parks those grains instead.
CATCH_DEPTH, CATCH_WALL, CATCH_MARGIN = 0.3, 0.1, 0.4


def material(young, poisson, friction):
    return (young, poisson, p["restitution"], friction)


# 1. Materials (Tables 5.1, 5.2) as dem.py's: the grain's own μ between grains, the steel's or the frame's against the
#    walls (the contact law takes the smaller μ of a pair); the surface (the sheet) is steel.
grain = material(p["grain_young"], p["grain_poisson"], p["friction"])
steel = material(p["sheet_young"], p["sheet_poisson"], p["steel_friction"])
materials = {"steel": steel, "frame": material(p["frame_young"], 0.3, p["frame_friction"]),
             "tray": material(p["frame_young"], 0.3, 0.0)}


def rig_walls():
    """The rig's triangles (n, 3, 3), their material indices, the materials, and the triangles of each flap."""
    quads = rig.walls()
    L, W = p["sheet_length"], p["sheet_width"]
    x0, x1, y0, y1 = -CATCH_MARGIN, L + CATCH_MARGIN, -CATCH_MARGIN, W + CATCH_MARGIN
    z0, z1 = -CATCH_DEPTH, -CATCH_DEPTH + CATCH_WALL
    quads += [("catch", "frame", [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)]),
              ("catch", "frame", [(x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)]),
              ("catch", "frame", [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)]),
              ("catch", "frame", [(x1, y1, z0), (x1, y1, z1), (x0, y1, z1), (x0, y1, z0)]),
              ("catch", "frame", [(x0, y1, z0), (x0, y1, z1), (x0, y0, z1), (x0, y0, z0)])]
    used = sorted({m for _, m, _ in quads}, key=list(materials).index)
    corners, kinds, flaps = [], [], {}
    for name, kind, (a, b, c, d) in quads:
        if name.startswith("flap"):
            flaps[name] = [len(corners), len(corners) + 1]
        corners += [(a, b, c), (a, c, d)]
        kinds += [used.index(kind)] * 2
    return np.array(corners, dtype=float), np.array(kinds, np.int32), [materials[m] for m in used], flaps


def neighbour_skin():
    """The Verlet skin [m]: neighbour_skin, or (0) twice the way the fastest grain covers between two list rebuilds, so
    that no contact is missed: 1.2 times the free-fall speed from the fill's top onto the slides or from the flaps into
    the catch tray, over rebuild_interval steps of dem_dt. The library's default (a fifth of the mean radius) let the
    stream's grains move more than half of it between rebuilds."""
    if p["neighbour_skin"] > 0:
        return p["neighbour_skin"]
    fall = max(rig.z_top - rig.z_slides, rig.z_flaps + CATCH_DEPTH)
    return 2.0 * 1.2 * (2.0 * GRAVITY * fall) ** 0.5 * p["rebuild_interval"] * p["dem_dt"]


def new_bed(time_step, positions, velocities=None, angular_velocities=None, orientations=None):
    """A bed of the grains (in rig order) at `positions` and the rig's walls."""
    bed = polyhedra_driver.PolyhedraBed(time_step, grain, gravity=(0, 0, -GRAVITY),
                                        max_neighbours=p["max_neighbours"],
                                        max_wall_neighbours=p["max_wall_neighbours"],
                                        rebuild_interval=p["rebuild_interval"], neighbour_skin=neighbour_skin(),
                                        backend=p["polyhedra_backend"])
    n = len(diameters)
    velocities = np.zeros((n, 3)) if velocities is None else velocities
    angular_velocities = np.zeros((n, 3)) if angular_velocities is None else angular_velocities
    orientations = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)) if orientations is None else orientations
    for k in range(n):
        bed.add_stone(POINT, 0.5 * diameters[k], p["grain_density"], positions[k], orientations[k], velocities[k],
                      angular_velocities[k])
    corners, kinds, wall_materials, flaps = rig_walls()
    bed.set_walls(corners, kinds, wall_materials)
    return bed, corners, flaps


# 2. Settling in the closed hopper (uncoupled; the FEM waits at its handshake), on a bed of its own: the coupled bed's
#    walls take the sheet's surface at the handshake, before its first step. The coupled run starts from the settled
#    state (the seed's "settled under gravity, state saved and reused"). A resumed run takes its state from the
#    checkpoint: the bed is only built the same way.
options = coupled_dem.coupling_options(p)
restart = polyhedra_driver.restart_settings()
resuming = bool(restart and restart["resume_from"])
wall_start = time.monotonic()
settled = (centres, None, None, None)
if p["settle_s"] > 0 and not resuming:
    settling, _, _ = new_bed(p["dem_dt"], centres)
    steps, batch = int(round(p["settle_s"] / p["dem_dt"])), 500
    for done in range(0, steps, batch):
        settling.step(min(batch, steps - done))
    positions, orientations, velocities, angular_velocities, masses = settling.states()
    energy = 0.5 * float(np.sum(masses * np.sum(velocities ** 2, axis=1)))
    print(f"settled for {settling.time:.3f} s ({steps} steps, {time.monotonic() - wall_start:.1f} s): translational "
          f"kinetic energy {energy:.3e} J; {settling.backend[0]}", flush=True)
    settled = (positions, velocities, angular_velocities, orientations)
    del settling
engine, corners, flaps = new_bed(p["dem_dt"], *settled)
if restart:
    engine.set_restart(**restart)
subcycles = engine.connect(endpoint, scheme=options["scheme"], surface_material=steel, timeout=options["timeout"],
                           subcycles=options.get("subcycles", 0), implicit_tolerance=options["implicitTolerance"],
                           implicit_max_iterations=options["implicitMaxIterations"],
                           implicit_relaxation=options["implicitRelaxation"], aitken=options["aitken"])
figures = engine.figures()
window_length = figures["window_length"]
windows = int(round(p["duration_s"] / window_length))
masses = engine.states()[4]
total_mass = float(masses.sum())
backend, reason = engine.backend
print(f"{len(diameters)} grains, {total_mass:.4f} kg, diameters {diameters.min() * 1e3:.2f}-"
      f"{diameters.max() * 1e3:.2f} mm, hopper {rig.x0:.3f}-{rig.x1:.3f} m filled to {rig.z_top - rig.z_slides:.3f} m; {backend} ({reason})",
      flush=True)
print(f"coupled: dt={engine.dt:.3e} s, {subcycles} DEM steps per FEM step, {windows} windows ({options['scheme']}, "
      f"neighbour skin {neighbour_skin() * 1e3:.2f} mm, "
      f"{int(figures['surface_triangles'])} surface triangles, spheres as one-point polyhedra, standalone driver)",
      flush=True)


# 3. The windows. Each window the flaps' corners move along the chords of their turn over it (rig.turned at the
#    window's ends: after the window they are where the turn puts them). Every bulk_record_s the masses are counted
#    (rig.bulk_figures, all grains read across once); the records in between repeat those figures. The mean nodal
#    forces of the final span (average_s) are summed for the static FEM reference.
closed = {name: corners[t].reshape(-1, 3) for name, t in flaps.items()}
bulk_every = max(1, int(round(p["bulk_record_s"] / p["fem_dt"])))
state = {"force_sum": None, "force_windows": 0, "bulk": {}, "flaps_moving": False}


def move_flaps(t):
    """Sets the flaps' corner velocities for the window starting at t (since the handshake)."""
    before, after = rig.flap_angle(t), rig.flap_angle(t + window_length)
    if after == before and not state["flaps_moving"]:
        return
    for name, triangles in flaps.items():
        chord = rig.turned(closed[name], name, after) - rig.turned(closed[name], name, before)
        engine.set_wall_node_velocities(triangles, chord / window_length)
    state["flaps_moving"] = after != before


inertia = 0.4 * masses * (0.5 * diameters) ** 2  # a sphere's, 2/5 m r^2


def kinetic_energy(velocities, angular_velocities):
    """Translational and rotational, as YADE's utils.kineticEnergy [J]."""
    return 0.5 * float(np.sum(masses * np.sum(velocities ** 2, axis=1))
                       + np.sum(inertia * np.sum(angular_velocities ** 2, axis=1)))


def bulk_figures(t):
    positions, _, velocities, angular_velocities, _ = engine.states()
    nodes, _ = engine.surface_state()
    return {**rig.bulk_figures(t, positions, velocities, masses, nodes),
            "kinetic_energy": kinetic_energy(velocities, angular_velocities)}


every = solvers.progress_period(p)
recorder, first, saved = polyhedra_driver.window_recorder(engine, out, restart)
if saved:
    state.update(saved["state"])
coupled_start = time.monotonic()
script_time = 0.0  # this script's own share: the flaps, the counts, the time series, the checkpoints' files
for w in range(first, windows):
    script_start = time.monotonic()
    move_flaps(w * window_length)
    script_time += time.monotonic() - script_start
    engine.window()
    window_done = time.monotonic()
    figures = engine.figures()
    t = (w + 1) * window_length
    if (w + 1) % bulk_every == 0 or not state["bulk"]:
        state["bulk"] = bulk_figures(t)
    if t >= p["duration_s"] - p["average_s"] - 1e-12:
        forces = engine.surface_state()[1]
        state["force_sum"] = forces if state["force_sum"] is None else state["force_sum"] + forces
        state["force_windows"] += 1
    force = [figures[f"total_force_{k}"] for k in "xyz"]
    recorder.append(time=figures["time"], interface_force=force, **state["bulk"],
                    interface_work_dem=figures["interface_work_dem"], interface_work_fem=figures["interface_work_fem"])
    polyhedra_driver.complete_pending_checkpoint(engine, recorder, w + 1, state=state)
    if (w + 1) % every == 0:
        b = state["bulk"]
        print(f"t={figures['time']:.4f} s  window {w + 1}/{windows}  hopper {b['hopper_mass']:.3f} kg  passed "
              f"{b['passed_mass']:.3f} kg  sheet {b['sheet_mass']:.3f} kg  Fz {-force[2]:.3f} N  "
              f"{time.monotonic() - coupled_start:.1f} s", flush=True)
    script_time += time.monotonic() - window_done
engine.finalize()
wall_time = time.monotonic() - wall_start
nodes, _ = engine.surface_state()
# Grains below the catch tray's floor have left the rig: said, with the fastest grain, so that a run shows it.
positions, _, velocities, _, _ = engine.states()
escaped = np.flatnonzero(positions[:, 2] < -CATCH_DEPTH - 0.05)
fastest = int(np.argmax(np.sum(velocities ** 2, axis=1)))
print(f"{escaped.size} grains below the catch tray (first: {escaped[:5].tolist()}); the fastest grain {fastest} at "
      f"{np.round(positions[fastest], 4).tolist()} m, {np.round(velocities[fastest], 3).tolist()} m/s", flush=True)
# 4. What the post-processing reads (dem_info.json, dem_timeseries.h5): dem.py's fields.
info = {**engine.coupling_info(options["scheme"]), "steps": windows * subcycles, "dt": engine.dt,
        "wall_time_s": wall_time,
        "particles": len(diameters), "total_grain_mass_kg": total_mass, "diameter_min_m": float(diameters.min()),
        "diameter_max_m": float(diameters.max()), "flow_plane_z": rig.z_flow, "flaps_z": rig.z_flaps,
        "final_kinetic_energy_j": state["bulk"]["kinetic_energy"], "mean_force_windows": state["force_windows"],
        "polyhedra_backend": backend, "dem_driver": "standalone", "polyhedra_time_s": figures["polyhedra_time"],
        "script_time_s": script_time, "coupled_wall_time_s": time.monotonic() - coupled_start,
        "grains_below_catch_tray": int(escaped.size)}
results.save_dem_outputs(out, recorder, info, triangles=engine.surface_triangles(), node_positions=nodes,
                         mean_nodal_forces=state["force_sum"] / max(1, state["force_windows"]))
print(f"done: {windows * subcycles} steps in {wall_time:.1f} s; DEM {figures['polyhedra_time']:.1f} s, FEM wait "
      f"{figures['wait_time']:.1f} s, bridge {figures['bridge_time']:.3f} s over {int(figures['windows'])} exchanges, "
      f"script {script_time:.1f} s", flush=True)
