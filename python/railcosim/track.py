"""The straight ballasted track of the track cases: a quarter of it, sleepers + pads + rail in FreeFEM
(freefem_scripts/examples/track.edp on track.geo) over a bed of spheres in YADE on a base (subgrade) wall.

Axes: x along the track (0 = the plane of symmetry through the loaded sleeper), y across it (0 = the track's centre
line), z up (0 = the sleepers' base). The quarter holds half of the sleeper at x = 0 and `sleepers - 1` whole ones
at `sleeper_spacing`, each half a sleeper long, and ends at end_x = (sleepers - 1/2) spacing, the middle of a crib.
The ballast lies under the sleepers, between frictionless mirror walls at x = 0, x = end_x and y = 0 (the planes of
symmetry) and a frictionless wall at the shoulder's edge, on a base wall whose contact stiffness stands for the
subballast and the formation (Irazábal 2017 §7.2.1, Table 7.1), or (subgrade = "layers") on FreeFEM subgrade layers
in the track's mesh, coupled on their top face (implicit scheme only: cases/track_stiffness/README.md).

A half track (x_symmetry = false, cases/train_passage: a moving wheel breaks the symmetry in x) holds `sleepers`
whole sleepers at 0, spacing, ... and runs from start_x = -spacing/2 to end_x, both the middle of a crib, with the
same mirror walls there; a loosely packed zone under `loose_zone` sleepers from sleeper `loose_zone_first` on
(Irazábal 2017 §7.2.3: packed with friction) may be set for it.

A case uses it in four places:
    case.py   fem_script = track.FEM_SCRIPT; fem_arguments(p) -> track.fem_arguments(p) (+ its load options)
    dem.py    bed = track.TrackBed(p, out)  (materials, walls, the packed bed from the cache, contact engines)
              coupling = dem.coupling_engine(material=bed.sleeper_material, ...)
              O.engines = bed.engines() + [coupling, NewtonIntegrator(gravity=(0, 0, -9.81))]
    postprocess: track.seat_forces(...), track.winkler_deflection(...)
    bed.py    track.TrackBed(p, out) in a preparation run, so that the bed is packed before the FEM side waits
The parameters it reads are the [parameters] and [fem] names of cases/track_stiffness/case.toml (and, for the half
track, x_symmetry, loose_zone, loose_zone_first and loose_friction of cases/train_passage/case.toml; absent, the
quarter without a loose zone).
"""
import math
import os

import numpy as np

from railcosim import bedcache, solvers

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the repository
FEM_SCRIPT = "examples/track.edp"
BED_INFO = "bed.json"  # the preparation run's figures of the packed bed (base_z [m], spheres, cache file)
GRAVITY = 9.81
# UIC60 rail (EN 13674-1): cross-section area [m^2] and second moment about the horizontal axis [m^4].
UIC60_AREA = 76.70e-4
UIC60_SECOND_MOMENT = 3038.3e-8
# EN 13450 grading (Irazábal 2017 Table 2.1): sieve sizes [m] and mid-points of the passing bands.
EN13450_SIEVES = (0.0224, 0.0315, 0.040, 0.050, 0.063)
EN13450_PASSING = (0.0, 0.125, 0.475, 0.85, 1.0)
CLOUD_SOLID_FRACTION = 0.3  # random placement jams near 0.38; a frictionless bed settles to about 0.6
PACKING_DAMPING = 0.3  # YADE's non-viscous damping while the packing settles
PLATE_SPEED = 0.3  # m/s, the plate's highest speed
PLATE_OVERLAP = 5e-4  # m: grains may overlap the plate by this much (elastic contact) and still count as under it
PACKING_PROCEDURE = 8  # part of the cache key: raised whenever _pack changes
COMPACTION_HOLD_S = 0.1  # s the bed rests under the plate, and half of it after it is removed
REST_S = 0.05  # s the bed rests with the test's materials before it is kept


def rail_rectangle(area=UIC60_AREA, second_moment=UIC60_SECOND_MOMENT):
    """(width, height) [m] of the rectangle with the rail's area A and second moment I: h = sqrt(12 I / A), b = A / h
    (UIC60: 35.2 mm by 218.0 mm)."""
    height = math.sqrt(12.0 * second_moment / area)
    return area / height, height


def half_track(p):
    """True for the half track (no plane of symmetry in x: x_symmetry = false)."""
    return not p.get("x_symmetry", True)


def start_x(p):
    """x [m] where the track's scene starts: 0 (the quarter's plane of symmetry) or, for the half track, -spacing/2
    (the middle of the crib before the first sleeper)."""
    return -0.5 * p["sleeper_spacing"] if half_track(p) else 0.0


def loose_range(p):
    """(x from, x to) [m] of the loosely packed zone (the cribs' middles around sleepers loose_zone_first to
    loose_zone_first + loose_zone - 1), or None."""
    count = p.get("loose_zone", 0)
    if count <= 0:
        return None
    first = p["loose_zone_first"]
    return ((first - 0.5) * p["sleeper_spacing"], (first + count - 0.5) * p["sleeper_spacing"])


def end_x(p):
    """x [m] of the quarter's far plane of symmetry, the middle of the crib after the last sleeper."""
    return (p["sleepers"] - 0.5) * p["sleeper_spacing"]


def bed_width(p):
    """y [m] of the shoulder's wall: half a sleeper and the shoulder beyond it."""
    return 0.5 * p["sleeper_length"] + p["shoulder_width"]


def pwave_time_step(radii, young, density):
    """YADE's utils.PWaveTimeStep for spheres of one material: the smallest radius over the P-wave speed
    sqrt(E / rho) [s] (the track's DEM step is dem_dt_safety times it, whichever driver runs the bed)."""
    return float(np.min(radii)) / math.sqrt(young / density)


def cached_bed(key, out, pack):
    """(bed rows x, y, z, r; base z [m]; cache file) of the packing `key` (the parameters that define it): packed once
    by pack() -> (bed, base_z) and kept in the bed cache (bedcache), written whole or not at all."""
    cache = bedcache.path("track", key, fallback=os.path.join(out, "cache"))
    with bedcache.exclusive(cache) as found:
        if not found:
            bed, base_z = pack()
            partial = f"{cache}.{os.getpid()}.npz"
            np.savez(partial, bed=bed, base_z=base_z)
            os.replace(partial, cache)
    with np.load(cache) as saved:
        return saved["bed"], float(saved["base_z"]), cache


def highest_under_sleepers(p, bed):
    """z [m] of the highest grain top under a sleeper's base, of a bed of rows (x, y, z, r): the packed bed is lifted
    by minus this, so that the track rests on it from the start."""
    half_width = 0.5 * p["sleeper_width"]
    under = (np.abs(bed[:, 0] - p["sleeper_spacing"] * np.rint(bed[:, 0] / p["sleeper_spacing"])) < half_width) & \
            (bed[:, 1] < 0.5 * p["sleeper_length"])
    return float(np.max(bed[under, 2] + bed[under, 3]))


def stations(p):
    """x [m] of the deflection line's points: every sixth of a spacing (the seats and the mid-spans among them),
    start_x to end_x."""
    first = -3 if half_track(p) else 0
    return [k * p["sleeper_spacing"] / 6 for k in range(first, 6 * p["sleepers"] - 2)]


def fem_arguments(p):
    """track.edp's options for the track of parameters p (without the load's; with subgrade = "layers" the layers'
    top, baseZ, is the packed bed's base: BED_INFO of the preparation run)."""
    width, height = rail_rectangle()
    layers = p["subgrade"] == "layers"
    return {"geo": os.path.join(ROOT, "freefem_scripts", "examples", "track.geo"),
            "sleepers": p["sleepers"], "xStart": start_x(p), "spacing": p["sleeper_spacing"],
            "sleeperWidth": p["sleeper_width"],
            "sleeperHalfLength": 0.5 * p["sleeper_length"], "sleeperHeight": p["sleeper_height"],
            "padLength": p["pad_length"], "padThickness": p["pad_thickness"], "padStiffness": p["pad_stiffness"],
            "railWidth": width, "railHeight": height, "railY": 0.5 * p["rail_gauge"],
            "meshSize": p["mesh_size"], "railMeshSize": p["rail_mesh_size"], "sleeperE": p["sleeper_young"],
            "sleeperRho": p["sleeper_density"], "railE": p["rail_young"], "railRho": p["rail_density"],
            "rayleighMass": p["rayleigh_mass"], "stations": ",".join(f"{x:.6g}" for x in stations(p)),
            "subballastThickness": p["subballast_thickness"] if layers else 0.0,
            "formationThickness": p["formation_thickness"] if layers else 0.0,
            "subballastE": p["subballast_young"], "formationE": p["formation_young"],
            "bedWidth": bed_width(p), "layerMeshSize": p["layer_mesh_size"],
            **({"mesh": os.path.abspath(p["fem_mesh"])} if p.get("fem_mesh") else {})}


def check(p):
    """The track cases' shared parameter problems (a list; empty: none): what the standalone driver does not hold
    (railcosim.track_driver.check) and a missing fem_mesh."""
    problems = []
    if p.get("dem_driver", "yade") == "standalone":
        from railcosim import track_driver
        problems += track_driver.check(p)
    if p.get("fem_mesh") and not os.path.isfile(p["fem_mesh"]):
        problems.append(f"fem_mesh: no such file {p['fem_mesh']} (a fem/track.msh of an earlier run of this track)")
    return problems


def dem_script(p, script, *arguments):
    """The command of a DEM script of cases/track_stiffness (the track cases' bed.py, dem.py, dem_driver.py) on the
    dem_driver's interpreter: YADE (`railcosim yade`), or this Python with the standalone driver (the polyhedra library,
    railcosim.track_driver) on dem_threads OpenMP threads."""
    path = os.path.join(ROOT, "cases", "track_stiffness", script)
    if p.get("dem_driver", "yade") == "yade":
        return [os.path.join(ROOT, "railcosim"), "yade", path, *arguments]
    return solvers.library_dem_command(p, path, *arguments)


def dem_command(p, endpoint, out):
    """The track cases' DEM participant: dem.py (YADE) or dem_driver.py (dem_driver = "standalone": the polyhedra
    library), PARAMETERS.json ENDPOINT OUTDIR; its records hold the interface's nodal forces, the base's force and the
    kinetic energy."""
    script = "dem.py" if p.get("dem_driver", "yade") == "yade" else "dem_driver.py"
    return dem_script(p, script, os.path.join(out, "parameters.json"), endpoint, out)


def grading(size_scale):
    """(sieve sizes [m] times size_scale, cumulative passing, mean sphere volume [m^3]) of the EN 13450 grading, the
    mass fraction of each band taken at its mid diameter."""
    sizes = [d * size_scale for d in EN13450_SIEVES]
    passing = list(EN13450_PASSING)
    mean_volume = 1.0 / sum((passing[k + 1] - passing[k]) / (math.pi / 6 * (0.5 * (sizes[k] + sizes[k + 1])) ** 3)
                            for k in range(len(sizes) - 1))
    return sizes, passing, mean_volume


def base_young(p):
    """Young's modulus [Pa] of the base wall for the bed's grain size. The base's compliance is that of its grain
    contacts: N ~ A / d^2 Hertz contacts, each of stiffness k ~ E*^(2/3) (F d)^(1/3) with F ~ sigma d^2, so the base
    stiffness ~ E*^(2/3) / d. Grains size_scale times larger keep the thesis's base stiffness (its E calibrated for the
    EN 13450 grading) with E* times size_scale^(3/2)."""
    return p["base_young"] * p["size_scale"] ** 1.5


def bed_structure(bed, samples=200000, seed=0):
    """(porosity of the bed's interior, mean coordination number of its interior grains) of a packed bed, rows
    (x, y, z, r). The interior is the bed's extent less one largest radius at every side, away from the walls' and
    the surface's looser layers, which weigh much in a bed a few grains deep (the margin is a choice: a thinner
    interior moves the figure by a few points); its porosity is estimated from random points (200,000 points:
    sampling error ~0.1 %; sampled_porosity). Grains touch when their centres are closer than the sum of their
    radii."""
    from scipy.spatial import cKDTree
    centres, radii = bed[:, :3], bed[:, 3]
    margin = radii.max()
    low, high = centres.min(axis=0) - radii.min() + margin, centres.max(axis=0) + radii.min() - margin
    if np.any(high <= low):
        raise ValueError(f"the bed is too small for an interior one largest radius ({margin:.3f} m) from its sides")
    tree = cKDTree(centres)
    porosity = sampled_porosity(bed, low, high, samples=samples, seed=seed, tree=tree)
    pairs = np.array(sorted(tree.query_pairs(2.0 * radii.max())), dtype=int).reshape(-1, 2)
    gap = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) - radii[pairs].sum(axis=1)
    contacts = np.bincount(pairs[gap < 0].ravel(), minlength=len(bed))
    interior = np.all((centres > low) & (centres < high), axis=1)
    return porosity, float(contacts[interior].mean()) if interior.any() else float("nan")


def sampled_porosity(bed, low, high, inside=None, samples=200000, seed=0, tree=None):
    """Porosity of a bed of spheres, rows (x, y, z, r), in the part of the box [low, high] where `inside(points)`
    (points (n, 3) -> bool mask; None: the whole box) holds: sampled_porosities with that one region."""
    whole = lambda points: np.ones(len(points), dtype=bool)
    return sampled_porosities(bed, low, high, {"region": inside or whole}, samples, seed, tree)["region"]


def sampled_porosities(bed, low, high, regions, samples=200000, seed=0, tree=None):
    """{name: porosity} of a bed of spheres, rows (x, y, z, r), in each region {name: inside(points) -> bool mask} of
    the box [low, high], from one set of random points in the box: a point is solid when it lies in one of its 16
    nearest spheres by centre (exact unless 16 other centres lie nearer than that of a sphere holding it, which needs
    spheres many times smaller than their neighbours). Sampling error about sqrt(n(1-n)/m) for m points in a region
    (0.1 % at 200,000). A region no point falls in is refused."""
    from scipy.spatial import cKDTree
    tree = tree if tree is not None else cKDTree(bed[:, :3])
    low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
    points = low + (high - low) * np.random.default_rng(seed).random((samples, 3))
    masks = {name: np.asarray(inside(points), dtype=bool) for name, inside in regions.items()}
    for name, mask in masks.items():
        if not mask.any():
            raise ValueError(f"no sample point lies in the region {name}: it is empty or outside the box")
    used = np.logical_or.reduce(list(masks.values()))  # one nearest-sphere query for the points of any region
    k = min(16, len(bed))
    distance, nearest = (a.reshape(int(used.sum()), k) for a in tree.query(points[used], k=k))  # (n,) when k = 1
    solid = np.zeros(len(points), dtype=bool)
    solid[used] = (distance < bed[:, 3][nearest]).any(axis=1)
    return {name: 1.0 - float(np.mean(solid[mask])) for name, mask in masks.items()}


def sleeper_nodes(node_positions, base_z):
    """Which interface nodes (nodes, 3) lie on the sleepers' bases (the rest, with subgrade layers, on the layers' top
    face at base_z)."""
    return np.asarray(node_positions)[:, 2] > 0.5 * base_z


def seat_forces(nodal_forces, node_positions, p, base_z):
    """Vertical force of the ballast on each sleeper [N], (windows, sleepers) from the interface's nodal forces
    (windows, nodes, 3) and positions (nodes, 3): sleeper nodes within half a spacing of a sleeper's centre belong
    to it."""
    positions = np.asarray(node_positions)
    owner = np.where(sleeper_nodes(positions, base_z), np.rint(positions[:, 0] / p["sleeper_spacing"]), -1).astype(int)
    fz = np.asarray(nodal_forces)[..., 2]
    return np.stack([fz[:, owner == k].sum(axis=1) for k in range(p["sleepers"])], axis=1)


def winkler_deflection(x, wheel_load, modulus, bending_stiffness, period=None, images=6):
    """Deflection [m] of a beam on a Winkler foundation under a point load (Zimmermann; Irazábal 2017 eqs 7.2-7.5):
    w(x) = Q beta / (2 k) exp(-beta |x|) (cos beta |x| + sin beta |x|), beta = (k / (4 EI))^(1/4), k the support
    modulus [N/m^2], EI [N m^2]. With `period` the loads repeat every `period` along x (mirror images of the load
    through the planes of symmetry at x = 0 and period / 2); `images` images on each side."""
    beta = (modulus / (4.0 * bending_stiffness)) ** 0.25
    x = np.asarray(x, dtype=float)
    shifts = [0.0] if period is None else [k * period for k in range(-images, images + 1)]
    w = np.zeros_like(x)
    for s in shifts:
        r = beta * np.abs(x - s)
        w += wheel_load * beta / (2.0 * modulus) * np.exp(-r) * (np.cos(r) + np.sin(r))
    return w


def winkler_mirrored(x, loads, modulus, bending_stiffness, start, end):
    """Winkler deflection [m] at x of point loads [(x_i, Q_i)] on a beam whose ends `start` and `end` are mirror planes
    (the half track's rail ends, in the middle of a crib): each load's image through `start`, and both repeated every
    2 (end - start) (winkler_deflection's periodic images)."""
    period = 2.0 * (end - start)
    x = np.asarray(x, dtype=float)
    w = np.zeros_like(x)
    for c, q in loads:
        for image in (c, 2.0 * start - c):
            w += winkler_deflection(x - image, q, modulus, bending_stiffness, period=period)
    return w


class TrackBed:
    """The YADE side of the track scene: materials, the base wall and the mirror walls, the ballast bed packed once
    (cached by bedcache), and the contact engines. Construct inside YADE."""

    PACKING_KEYS = ("sleepers", "sleeper_spacing", "sleeper_length", "sleeper_width", "ballast_depth", "shoulder_width",
                    "size_scale", "packing_young", "ballast_young", "ballast_poisson", "ballast_density",
                    "ballast_friction", "rolling_friction", "wall_rolling_friction", "base_young", "base_poisson",
                    "base_friction", "mirror_young", "restitution", "packing_settle_s", "consolidation_pressure",
                    "dem_dt_safety", "seed")

    def __init__(self, p, out):
        from yade import O, utils
        from yade.wrapper import BallastMat
        self.p = p
        self.start_x = start_x(p)
        self.end_x = end_x(p)
        self.width = bed_width(p)
        self.depth = p["ballast_depth"]

        # 1. Materials (Irazábal 2017 Table 7.1): ballast, sleepers, base (subballast + formation), mirror walls.
        def material(young, poisson, friction, rolling, density=1000.0):
            return O.materials.append(BallastMat(young=young, poisson=poisson, density=density,
                                                 frictionAngle=math.atan(friction), restitution=p["restitution"],
                                                 rollingFriction=rolling))
        self.ballast = material(p["ballast_young"], p["ballast_poisson"], p["ballast_friction"], p["rolling_friction"],
                                p["ballast_density"])
        self.packing = material(p["packing_young"], p["ballast_poisson"], 0.0, 0.0, p["ballast_density"])
        self.sleeper = material(p["sleeper_young"], 0.2, p["sleeper_friction"], p["wall_rolling_friction"])
        self.base = material(base_young(p), p["base_poisson"], p["base_friction"], p["wall_rolling_friction"])
        self.mirror = material(p["mirror_young"], 0.2, 0.0, p["wall_rolling_friction"])
        self.loose = None  # the loose zone's packing material (Irazábal §7.2.3), only with one
        if loose_range(p):
            self.loose = material(p["packing_young"], p["ballast_poisson"], p["loose_friction"], p["rolling_friction"],
                                  p["ballast_density"])

        # 2. The bed, packed without friction (Irazábal §6.4.2) and cut at the sleepers' base, from the cache; its
        #    highest grain under the sleepers at z = 0 so that the track rests on it from the start.
        layers = {"subgrade": "layers"} if p["subgrade"] == "layers" else {}  # a concrete base while packing
        # The half track and its loose zone enter the key only when set (the quarter's cached beds keep their keys).
        half = {"x_symmetry": False} if half_track(p) else {}
        loose = {k: p[k] for k in ("loose_zone", "loose_zone_first", "loose_friction")} if loose_range(p) else {}
        key = {"procedure": PACKING_PROCEDURE, **{k: p[k] for k in self.PACKING_KEYS}, **layers, **half, **loose}
        bed, self.base_z, self.cache = cached_bed(key, out, self._pack)
        self._scene(bed, self.base_z)
        self.bed = bed

    def _scene(self, bed, base_z, packing=False):
        """The bed's bodies: the base wall at base_z (subgrade = "wall"; with "layers" only while packing, then of the
        sleepers' concrete, as the coupled surface will be), the mirror walls, the grains of `bed` (x, y, z, r) of the
        ballast's material."""
        from yade import O, utils
        self.base_wall = None
        if self.p["subgrade"] == "wall" or packing:  # with FreeFEM layers the coupled surface is the base
            self.base_wall = O.bodies.append(utils.wall(position=base_z, axis=2, sense=1,
                                                        material=O.materials[self.sleeper if packing and self.p[
                                                            "subgrade"] == "layers" else self.base]))
        self.mirrors = [O.bodies.append(utils.wall(position=pos, axis=axis, sense=sense,
                                                   material=O.materials[self.mirror]))
                        for axis, pos, sense in ((0, self.start_x, 1), (0, self.end_x, -1), (1, 0.0, 1),
                                                 (1, self.width, -1))]
        self.spheres = [O.bodies.append(utils.sphere(row[:3], row[3], material=O.materials[self.ballast]))
                        for row in bed]

    @property
    def sleeper_material(self):
        from yade import O
        return O.materials[self.sleeper]

    @property
    def mass(self):
        from yade import O
        return sum(O.bodies[i].state.mass for i in self.spheres)

    def engines(self, boxes=False):
        """YADE's engines up to the contact loop and the rolling friction: a case appends its coupling engine and the
        integrator. boxes: also box bodies (rigid sleepers, cases/track_stiffness/sleeper_test.py)."""
        from yade.wrapper import (Bo1_Box_Aabb, Bo1_Facet_Aabb, Bo1_Sphere_Aabb, Bo1_Wall_Aabb,
                                  BoundedRollingFrictionEngine, ForceResetter, Ig2_Box_Sphere_ScGeom,
                                  Ig2_Facet_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom, Ig2_Wall_Sphere_ScGeom,
                                  InsertionSortCollider, InteractionLoop, Ip2_BallastMat_BallastMat_BallastPhys,
                                  Law2_ScGeom_BallastPhys_Ballast)
        bounds = [Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()] + ([Bo1_Box_Aabb()] if boxes else [])
        geometries = [Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()] + \
            ([Ig2_Box_Sphere_ScGeom()] if boxes else [])
        return [ForceResetter(), InsertionSortCollider(bounds),
                InteractionLoop(geometries, [Ip2_BallastMat_BallastMat_BallastPhys()],
                                [Law2_ScGeom_BallastPhys_Ballast()]),
                BoundedRollingFrictionEngine()]

    def base_force(self):
        """Vertical force of the bed on the base wall [N] (positive downwards) in the last step; 0 without a wall."""
        from yade import O
        return 0.0 if self.base_wall is None else -O.forces.f(self.base_wall)[2]

    def _pack(self):
        """Rains a loose cloud of the grading into the box over the base, lets it settle without friction under gravity
        for packing_settle_s, cuts it at ballast_depth, levels it under a plate, lets it rest with the test's materials
        and lifts it (and the base) so that the highest grain under a sleeper touches z = 0. Returns the bed, rows
        (x, y, z, r), and the base's height z [m]."""
        from yade import O, pack, utils
        from yade.wrapper import NewtonIntegrator
        p = self.p
        sizes, passing, mean_volume = grading(p["size_scale"])
        floor = -self.depth
        O.bodies.append(utils.wall(position=floor, axis=2, sense=1, material=O.materials[self.mirror]))
        for axis, pos, sense in ((0, self.start_x, 1), (0, self.end_x, -1), (1, 0.0, 1), (1, self.width, -1)):
            O.bodies.append(utils.wall(position=pos, axis=axis, sense=sense, material=O.materials[self.mirror]))
        top = floor + 2.2 * self.depth + sizes[-1]  # the cloud's solid fraction 0.3 settles to about twice that
        cloud = pack.SpherePack()
        volume = (self.end_x - self.start_x) * self.width * (top - floor)
        cloud.makeCloud((self.start_x, 0, floor), (self.end_x, self.width, top), psdSizes=sizes, psdCumm=passing,
                        distributeMass=True, num=int(CLOUD_SOLID_FRACTION * volume / mean_volume), seed=p["seed"])
        # A loose zone (Irazábal 2017 §7.2.3: the bump packed by gravity with mu = 0.6 there, 0 elsewhere): its grains
        # settle and are consolidated with friction loose_friction and the ballast's rolling friction.
        zone = loose_range(p)
        ids = [O.bodies.append(utils.sphere(c, r, material=O.materials[
            self.loose if zone is not None and zone[0] <= c[0] < zone[1] else self.packing])) for c, r in cloud]
        # Numerical damping speeds the settling of the packing only (the coupled run has none).
        O.engines = self.engines()[:-1] + [NewtonIntegrator(damping=PACKING_DAMPING, gravity=(0, 0, -GRAVITY))]
        O.dt = p["dem_dt_safety"] * utils.PWaveTimeStep()
        O.run(max(1, int(p["packing_settle_s"] / O.dt)), True)
        # The auxiliary surface (Irazábal Table 6.6): the grains whose centres lie above the bed's depth removed, a
        # frictionless plate pressed on the rest at consolidation_pressure, so that every sleeper finds a level bed
        # with grains all over its base (not the few highest grains of a cut, which leave some sleepers hanging).
        for i in ids:
            if O.bodies[i].state.pos[2] > floor + self.depth - 0.5 * sizes[2]:  # tops near floor + depth
                O.bodies.erase(i)
        ids = [i for i in ids if O.bodies[i] is not None]
        start = max(O.bodies[i].state.pos[2] + O.bodies[i].shape.radius for i in ids)
        plate = O.bodies.append(utils.wall(position=start, axis=2, sense=-1, material=O.materials[self.mirror]))
        body = O.bodies[plate]
        target = p["consolidation_pressure"] * (self.end_x - self.start_x) * self.width
        chunk = 50
        for _ in range(max(1, int(COMPACTION_HOLD_S / O.dt / chunk))):
            # Lowered at up to PLATE_SPEED, slowing as the grains' force on it approaches the pressure's.
            body.state.vel = (0, 0, -PLATE_SPEED * max(0.0, 1.0 - O.forces.f(plate)[2] / target))
            O.run(chunk, True)
        body.state.vel = (0, 0, 0)
        level, pressed = body.state.pos[2], O.forces.f(plate)[2] / target
        O.bodies.erase(plate)
        O.run(max(1, int(0.5 * COMPACTION_HOLD_S / O.dt)), True)
        # The scene of the coupled run with the test's materials (friction, rolling friction, the ballast's stiffness,
        # the soft base): the bed rests under gravity, so that the coupled run starts from a bed at rest under its own
        # contact law.
        bed = np.array([[*O.bodies[i].state.pos, O.bodies[i].shape.radius] for i in ids])
        bed = bed[bed[:, 2] + bed[:, 3] <= level + PLATE_OVERLAP]  # none left above the plate's level
        O.bodies.clear()
        O.interactions.clear()
        self._scene(bed, floor, packing=True)
        O.engines = self.engines() + [NewtonIntegrator(damping=0.0, gravity=(0, 0, -GRAVITY))]  # BROF needs none
        O.dt = p["dem_dt_safety"] * utils.PWaveTimeStep()
        O.run(max(1, int(REST_S / O.dt)), True)
        print(f"bed packed: {len(self.spheres)} grains, plate level {level:.4f} m (its force {pressed:.2f} of the "
              f"pressure's at the end), kinetic energy at rest "
              f"{utils.kineticEnergy():.3g} J", flush=True)
        bed = np.array([[*O.bodies[i].state.pos, O.bodies[i].shape.radius] for i in self.spheres])
        lift = -highest_under_sleepers(p, bed)
        bed[:, 2] += lift
        O.bodies.clear()
        O.interactions.clear()
        return bed, floor + lift
