"""The track scene of railcosim.track on the polyhedra library without YADE (dem_driver = "standalone": the GPU
machine's path, where YADE cannot go). The same box, walls, materials, packing procedure and time-step rule as
track.TrackBed; the grains are spheres as one-point cores dilated by their radius, with the library's Hertz-Mindlin
contacts and bounded rolling friction (Irazábal 2017 §5.2.1; docs/polyhedra-driver.md).

Differences from TrackBed. In the packing: the loose cloud is placed by random sequential addition here, by YADE's
makeCloud there, both of the EN 13450 grading by mass at the same solid fraction (the mass uniform in log d within a
band here, the passing linear in d there); the numerical damping (track.PACKING_DAMPING, YADE's non-viscous damping)
acts on the translation only; each stage is a new bed, so contacts start anew and the step is recomputed from the
grains left (with friction 0 no contact carries a history); the walls' rolling friction acts while packing too, on
frictionless grains that nothing turns. In both runs: the walls are finite (WALL_MARGIN beyond the box), and their
forces (the plate's, the base's record) are means over a batch of steps or a window, YADE's the last step's.
The packed bed is cached apart from YADE's (the key holds the driver, not the backend: a bed packed on the CPU serves
a GPU run of the same parameters and the other way round).

Used by cases/track_stiffness/bed.py (packed_bed: the preparation run) and dem_driver.py (coupled_scene).
"""

import numpy as np

from railcosim import track
from railcosim.polyhedra_driver import PolyhedraBed, assemble_walls, rectangle

PACKING_PROCEDURE = 1  # part of the cache key: raised whenever _pack changes
MAX_NEIGHBOURS = 64    # candidates a stone: a 22 mm grain among 63 mm ones has many (cases/angle_of_repose)
SKIN_FRACTION = 0.05   # the neighbour lists' skin, a share of the mean diameter
WALL_MARGIN = 0.2      # m the walls reach beyond the box's edges, so that no grain meets a wall's edge
PLATE_CHUNK = 50       # steps between the consolidation plate's speed updates (TrackBed's)
PLACEMENT_TRIES = 400  # random positions tried for a grain of the cloud before the cloud is refused


def check(p):
    """What the standalone track scene does not hold, as a list of problems (empty: it runs)."""
    problems = []
    if p["subgrade"] != "wall":
        problems.append("dem_driver = standalone runs the base wall only (subgrade = wall): the FreeFEM layers' bed "
                        "is packed on a concrete base first, which the standalone packing does not do")
    if track.loose_range(p):
        problems.append("dem_driver = standalone has one stone material: a loosely packed zone (loose_zone > 0) "
                        "needs a second one while packing")
    return problems


def materials(p):
    """{name: (E, nu, restitution, mu)} and {name: eta_r} of the scene (Irazábal 2017 Table 7.1, as TrackBed's)."""
    e = p["restitution"]
    material = {"ballast": (p["ballast_young"], p["ballast_poisson"], e, p["ballast_friction"]),
                "packing": (p["packing_young"], p["ballast_poisson"], e, 0.0),
                "sleeper": (p["sleeper_young"], 0.2, e, p["sleeper_friction"]),
                "base": (track.base_young(p), p["base_poisson"], e, p["base_friction"]),
                "mirror": (p["mirror_young"], 0.2, e, 0.0)}
    rolling = {"ballast": p["rolling_friction"], "packing": 0.0, **{k: p["wall_rolling_friction"] for k in
                                                                     ("sleeper", "base", "mirror")}}
    return material, rolling


def walls(p, floor, top, plate=None):
    """(corners (n, 3, 3), {part: triangle indices}) of the box: the base at z = floor, the mirror walls at x =
    start_x, x = end_x and y = 0, the shoulder's wall at y = bed_width, up to z = top, and a plate facing down at z =
    plate (or none). Every wall reaches WALL_MARGIN beyond the box."""
    x0, x1, y1, m = track.start_x(p), track.end_x(p), track.bed_width(p), WALL_MARGIN
    lx, ly, lz = x1 - x0 + 2 * m, y1 + 2 * m, top - floor + 2 * m
    parts = {"base": rectangle((x0 - m, -m, floor), (lx, 0, 0), (0, ly, 0)),
             "mirrors": (rectangle((x0, -m, floor - m), (0, ly, 0), (0, 0, lz)) +      # x = start_x, facing +x
                         rectangle((x1, -m, floor - m), (0, 0, lz), (0, ly, 0)) +      # x = end_x, facing -x
                         rectangle((x0 - m, 0, floor - m), (0, 0, lz), (lx, 0, 0)) +   # y = 0, facing +y
                         rectangle((x0 - m, y1, floor - m), (lx, 0, 0), (0, 0, lz)))}  # y = bed_width, facing -y
    if plate is not None:
        parts["plate"] = rectangle((x0 - m, -m, plate), (0, ly, 0), (lx, 0, 0))
    return assemble_walls(parts)


class Stage:
    """One PolyhedraBed of the scene: spheres (rows x, y, z, r; velocities, angular velocities), the box's walls with
    the materials named in `wall_materials` {part: material}, the stones' material, and a time step of dem_dt_safety
    times the P-wave step (track.pwave_time_step: TrackBed's rule). The library's walls are fixed once stepped: each
    change of walls or materials (a packing phase) is a new Stage from the last one's states."""

    def __init__(self, p, spheres, stone, wall_materials, floor, top, plate=None, velocities=None, spins=None,
                 surface=None, damping=0.0):
        material, rolling = materials(p)
        corners, self.parts = walls(p, floor, top, plate)
        names = list(dict.fromkeys(wall_materials.values()))  # distinct, in order
        radii = spheres[:, 3]
        self.dt = p["dem_dt_safety"] * track.pwave_time_step(radii, material[stone][0], p["ballast_density"])
        skin = SKIN_FRACTION * 2.0 * float(np.mean(radii))
        self.bed = PolyhedraBed(self.dt, material[stone], gravity=(0.0, 0.0, -track.GRAVITY),
                                max_neighbours=MAX_NEIGHBOURS, neighbour_skin=skin, backend=p["polyhedra_backend"])
        walls_rolling = [rolling[n] for n in names] + ([rolling[surface]] if surface else [])  # the surface's last
        self.bed.set_rolling_friction(rolling[stone], walls_rolling)
        velocities = np.zeros((len(spheres), 3)) if velocities is None else velocities
        spins = np.zeros((len(spheres), 3)) if spins is None else spins
        core = np.zeros((1, 3))
        for row, v, w in zip(spheres, velocities, spins):
            self.bed.add_stone(core, row[3], p["ballast_density"], row[:3], (1.0, 0.0, 0.0, 0.0), v, w)
        of_triangle = np.zeros(len(corners), np.int32)
        for part, triangles in self.parts.items():
            of_triangle[triangles] = names.index(wall_materials[part])
        self.bed.set_walls(corners, of_triangle, [material[n] for n in names])
        self.bed.initialize()
        self.bed.set_damping(damping)
        self.radii = radii

    def run(self, seconds):
        self.bed.step(max(1, int(round(seconds / self.bed.dt))))

    def spheres(self):
        """(rows x, y, z, r; velocities; angular velocities; masses) now."""
        positions, _, velocities, spins, masses = self.bed.states()
        return np.column_stack([positions, self.radii]), velocities, spins, masses

    def kinetic_energy(self):
        """Translational and rotational kinetic energy of the spheres [J] (I = 2/5 m r^2)."""
        _, v, w, m = self.spheres()
        spin = np.sum(0.4 * m * self.radii ** 2 * np.sum(w * w, axis=1))
        return 0.5 * float(np.sum(m * np.sum(v * v, axis=1)) + spin)

    def force(self, part):
        """Mean force of the stones on the wall part over the last batch [N] (3)."""
        return self.bed.wall_force(self.parts[part])


def cloud(p, rng):
    """A loose cloud of the EN 13450 grading (times size_scale) by mass in the box over the packing's floor, at
    track.CLOUD_SOLID_FRACTION (TrackBed's) to one grain: (spheres, rows x, y, z, r; floor z; the cloud's top z).
    Random sequential addition, largest first, on a grid of cells of the largest diameter."""
    from ballast_clusters import sampleSieveSizes  # YADE-free (yade_engines/clusters)
    sizes, passing, mean_volume = track.grading(p["size_scale"])
    x0, x1, y1 = track.start_x(p), track.end_x(p), track.bed_width(p)
    floor = -p["ballast_depth"]
    top = floor + 2.2 * p["ballast_depth"] + sizes[-1]  # the cloud's solid fraction 0.3 settles to about twice that
    # Grains drawn until their volume reaches the solid fraction's (a batch of the expected count at a time).
    solid = track.CLOUD_SOLID_FRACTION * (x1 - x0) * y1 * (top - floor)
    diameters = np.zeros(0)
    while np.pi / 6.0 * np.sum(diameters ** 3) < solid:
        batch = 1e-3 * sampleSieveSizes(rng, int(solid / mean_volume) + 1, 100.0 * np.asarray(passing),
                                        [1e3 * s for s in sizes])
        diameters = np.concatenate([diameters, batch])
    diameters = diameters[:int(np.searchsorted(np.cumsum(np.pi / 6.0 * diameters ** 3), solid)) + 1]
    count = len(diameters)
    radii = np.sort(0.5 * diameters)[::-1]
    low, high, cell = np.array([x0, 0.0, floor]), np.array([x1, y1, top]), 2.0 * radii[0]
    grid, placed = {}, np.zeros((count, 4))
    for i, r in enumerate(radii):
        for _ in range(PLACEMENT_TRIES):
            c = low + r + (high - low - 2 * r) * rng.random(3)
            key = tuple((c // cell).astype(int))
            near = [j for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                    for j in grid.get((key[0] + dx, key[1] + dy, key[2] + dz), ())]
            if not near or np.all(np.linalg.norm(placed[near, :3] - c, axis=1) >= placed[near, 3] + r):
                placed[i] = (*c, r)
                grid.setdefault(key, []).append(i)
                break
        else:
            raise ValueError(f"track cloud: no room for grain {i + 1} of {count} (r = {r:.4f} m) in "
                             f"{PLACEMENT_TRIES} tries; the box is too small for the grading")
    return placed, floor, top


def _pack(p, log=print):
    """TrackBed._pack on the library: the cloud settles without friction for packing_settle_s, is cut at
    ballast_depth, consolidated under a frictionless plate at consolidation_pressure (lowered at up to PLATE_SPEED,
    slowing as its force nears the pressure's) for COMPACTION_HOLD_S, rests half that without the plate, then
    REST_S with the test's materials; lifted so that its highest grain under a sleeper touches z = 0. Returns the bed
    (rows x, y, z, r) and the base's height z [m]."""
    rng = np.random.default_rng(p["seed"])
    spheres, floor, top = cloud(p, rng)
    sizes, _, _ = track.grading(p["size_scale"])
    packing = {"base": "mirror", "mirrors": "mirror"}
    damping = track.PACKING_DAMPING  # numerical damping speeds the settling of the packing only (TrackBed's)
    stage = Stage(p, spheres, "packing", packing, floor, top, damping=damping)
    log(f"cloud: {len(spheres)} grains up to z = {top:.3f} m; packing step {stage.dt:.3e} s, {stage.bed.backend[0]}")
    stage.run(p["packing_settle_s"])
    spheres, v, w, _ = stage.spheres()
    kept = spheres[:, 2] <= floor + p["ballast_depth"] - 0.5 * sizes[2]  # tops near floor + depth
    spheres, v, w = spheres[kept], v[kept], w[kept]
    start = float(np.max(spheres[:, 2] + spheres[:, 3]))
    stage = Stage(p, spheres, "packing", {**packing, "plate": "mirror"}, floor, top, plate=start, velocities=v, spins=w,
                  damping=damping)
    target = p["consolidation_pressure"] * (track.end_x(p) - track.start_x(p)) * track.bed_width(p)
    level, pressed = start, 0.0  # the plate's height and its force over the pressure's
    for _ in range(max(1, int(track.COMPACTION_HOLD_S / stage.dt / PLATE_CHUNK))):
        speed = -track.PLATE_SPEED * max(0.0, 1.0 - pressed)
        stage.bed.set_wall_velocity(stage.parts["plate"], (0.0, 0.0, speed))
        stage.bed.step(PLATE_CHUNK)
        level += speed * PLATE_CHUNK * stage.dt
        pressed = stage.force("plate")[2] / target
    spheres, v, w, _ = stage.spheres()
    stage = Stage(p, spheres, "packing", packing, floor, top, velocities=v, spins=w, damping=damping)  # plate removed
    stage.run(0.5 * track.COMPACTION_HOLD_S)
    spheres, _, _, _ = stage.spheres()
    spheres = spheres[spheres[:, 2] + spheres[:, 3] <= level + track.PLATE_OVERLAP]  # none above the plate's level
    # The test's materials; the bed rests under gravity from positions alone, as TrackBed's.
    stage = Stage(p, spheres, "ballast", {"base": "base", "mirrors": "mirror"}, floor, top)
    stage.run(track.REST_S)
    bed, _, _, _ = stage.spheres()
    log(f"bed packed: {len(bed)} grains, plate level {level:.4f} m (its force {pressed:.2f} of the pressure's at "
        f"the end), kinetic energy at rest {stage.kinetic_energy():.3g} J")
    lift = -track.highest_under_sleepers(p, bed)
    bed[:, 2] += lift
    return bed, floor + lift


def packed_bed(p, out, log=print):
    """(bed rows x, y, z, r; base z [m]; cache file) of the parameters, packed once (_pack) and kept in the bed cache
    beside YADE's beds (the key holds the driver and this module's procedure)."""
    key = {"driver": "standalone", "procedure": PACKING_PROCEDURE, "track_procedure": track.PACKING_PROCEDURE,
           **{k: p[k] for k in track.TrackBed.PACKING_KEYS}}
    if track.half_track(p):
        key["x_symmetry"] = False
    return track.cached_bed(key, out, lambda: _pack(p, log))


def coupled_scene(p, bed, base_z):
    """The coupled run's Stage: the packed bed at rest with the test's materials on the base wall between the mirror
    walls; the sleepers' surface (rcp_connect) takes the sleeper material and its rolling friction."""
    top = float(np.max(bed[:, 2] + bed[:, 3])) + p["sleeper_height"]
    return Stage(p, bed, "ballast", {"base": "base", "mirrors": "mirror"}, base_z, top, surface="sleeper")
