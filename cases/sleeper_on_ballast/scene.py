"""The sleeper-on-ballast box test as data, without YADE: geometry, gradation, stones, sensors, load pattern, stages.

The scene is the box test of Song et al. 2019 as simulated by Ullrich 2022 (ch. 6, Table 6.1): a timber sleeper
on a ballast bed in a 3.2 x 1.0 x 0.8 m box, five pressure cells 0.13 m below the bed surface, rail-seat loads
ramped to 132 kN, cycled between 4.4 and 44 kN, ramped again. This module turns the case's parameters (the flat
dict of case.toml) into everything a DEM driver needs to build and prepare it, so that the YADE scripts of this
folder (bed.py, dem.py) and a driver without YADE read one description:

    scene = build(p)                 # geometry, gradation, materials, sensors, stages, load pattern
    stones = layer_stones(scene, rng, z_low, z_high)   # (shape, size) drawn for a layer of the bed
    cloud = place_cloud(scene, stones, region, rng)    # non-overlapping start positions and orientations
    core, r_d = stone_core(scene, shape, size)         # core vertices (body frame) and dilation radius
    templates(scene)                                   # the stone templates (triangles_per_stone), the cores' one source

Frame: the bed box spans x in [0, bed_length_m], y in [0, bed_width_m], z in [0, 0.8] (floor at z = 0); the
sleeper is centred on the box in x and y. Numpy and the shape library only (/usr/bin/python3 or YADE's Python).
"""
import itertools
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.environ.get("RAILCOSIM_ROOT", os.path.dirname(os.path.dirname(HERE)))
sys.path[:0] = [os.path.join(ROOT, "yade_engines", "clusters"), os.path.join(ROOT, "python")]
import ballast_clusters  # noqa: E402  (shape library, rotations, polyhedron mass properties)
from scipy.spatial import ConvexHull  # noqa: E402  (as the shape library's ConvexStone)
from railcosim import bedcache  # noqa: E402

# Ullrich 2022 Table 6.1 and Song et al. 2019 (fixed by the experiment, not parameters of the case).
SEED_BED = (3.2, 1.0, 0.8)            # m, the box of the test
SLEEPER_SIZE = (2.5, 0.2, 0.18)       # m, timber sleeper L x W x H
RAIL_SEAT_OFFSET = 0.7175             # m from the sleeper centre: x = 0.8825 and 2.3175 m in the 3.2 m box
RAIL_SEAT_SIZE = (0.15, 0.2)          # m, rail-seat patch (x, y)
SENSOR_SIZE = (0.22, 0.22, 0.1)       # m, pressure cells
SENSOR_SPACING = 0.38                 # m between sensor centres along x
SENSOR_COUNT = 5
GRAVITY = 9.81
# Porosity assumed to turn a volume into a stone count; the stage log reports the porosity reached.
ASSUMED_POROSITY = 0.40
SIZE_QUANTUM = 1.0 / 40.0             # sizes are rounded to 1/40 of the mean: shared templates, 2.5 % steps
MAX_ORIENTATIONS = 200                # random orientations place_cloud tries for a stone that fits in none of the first

BED_FORMAT = 1                        # version of the bed file layout (part of the cache key)
# Version of the bed that a parameter set makes, part of the cache key (bed_values). Bump it by hand with any change
# that makes another bed from the same parameters: preparation.py's stages, plate servo and trims, scene.py's draws,
# templates and placement, the drivers' stage engines, the polyhedra library's contact law or integration. Cached beds
# of the older code are then prepared again instead of being reused without notice. It enters the key only when it is
# not 1, the version of every bed cached before it existed, so that those keep their keys: a bump re-prepares beds
# once, and until then the desk's and CI's kept caches (~/.cache/railcosim/beds) stay valid. Not a hash of the
# sources: a comment, a log line or a load-run helper edited in these files would re-prepare every cached bed (16 min
# for the default bed on 2 cores, 7 min for the seed's on the GPU), and a hash of the Python alone would miss the C++
# library that moves the stones.
PREPARATION_VERSION = 1
CLUSTER_BED_FORMAT = 2                # version of the cluster beds' clusters (part of a cluster bed's key)


# ---------------------------------------------------------------------------------------------------
# Shapes: the library's 8 stones (unit sieve size, principal axes) as dilated polyhedra.
# ---------------------------------------------------------------------------------------------------
_TEMPLATES = {}


def reduced_hull(vertices, triangles, max_triangles):
    """(vertices, outward triangles) of a convex polyhedron of at most `max_triangles` triangles made from the convex
    template (vertices, triangles): a closed convex triangulated surface of V vertices has 2V - 4 triangles (Euler's
    relation V - E + F = 2 with 3F = 2E), so the hull keeps at most max_triangles // 2 + 2 of the template's vertices
    (an odd count gets one triangle fewer). Greedy: the vertex whose removal leaves the largest hull volume goes first,
    until few enough are left. The vertices kept are the template's own, in its body frame: every one stays a hull
    vertex (an extreme point of a set is one of every subset holding it), and the reduced hull lies inside the
    template. A template of at most `max_triangles` triangles is returned as it is."""
    if len(triangles) <= max_triangles:
        return vertices, triangles
    keep = list(range(len(vertices)))
    while len(keep) > max_triangles // 2 + 2:
        volumes = [ConvexHull(vertices[keep[:k] + keep[k + 1:]]).volume for k in range(len(keep))]
        del keep[int(np.argmax(volumes))]
    stone = ballast_clusters.ConvexStone(vertices[keep])
    return stone.vertices, stone.triangles


def library(triangles_per_stone=0):
    """The stone templates: the shape library's 8 stones (unit sieve size, principal axes), each as
    {name, vertices, triangles, feret, volume, area, curvature}; triangles_per_stone > 0: each reduced to a hull of at
    most that many triangles (reduced_hull; the seed's particle resolution, Ullrich 2022 §6.4.6), 0: the library's
    own hulls (12-66 triangles)."""
    if triangles_per_stone not in _TEMPLATES:
        templates = []
        for shape in ballast_clusters.loadShapeLibrary()["shapes"]:
            vertices, triangles = shape["vertices"], shape["triangles"]
            if triangles_per_stone > 0:
                vertices, triangles = reduced_hull(vertices, triangles, triangles_per_stone)
            feret, volume, area, curvature = ballast_clusters.steinerMeasures(vertices, triangles)
            templates.append({"name": shape["name"], "vertices": vertices, "triangles": triangles,
                              "clusters": shape["clusters"], "feret": feret, "volume": volume, "area": area,
                              "curvature": curvature})
        _TEMPLATES[triangles_per_stone] = templates
    return _TEMPLATES[triangles_per_stone]


def templates(scene):
    """The stone templates of a scene (library(scene's triangles_per_stone)): the one place the stones' cores come
    from, for both DEM drivers, the cloud placement and the volumes."""
    return library(scene["triangles_per_stone"])


def stone_core(scene, shape, size):
    """(core vertices in the body frame [m], dilation radius r_d [m]) of stone template `shape` of characteristic
    length `size`: r_d = dilation_fraction x size, and the core scaled so that the dilated stone's Feret diameter
    (its largest extent) is `size` (a Minkowski sum with a ball of radius r_d adds 2 r_d to every extent). A reduced
    template (triangles_per_stone) is scaled by its own Feret diameter: the characteristic length stays `size`."""
    stone = templates(scene)[shape]
    r_d = scene["dilation_fraction"] * size
    scale = (size - 2.0 * r_d) / stone["feret"]
    return stone["vertices"] * scale, r_d


def stone_volume(scene, shape, size):
    """Volume of the dilated stone [m^3] (Steiner formula, exact for a convex core)."""
    stone = templates(scene)[shape]
    r_d = scene["dilation_fraction"] * size
    s = (size - 2.0 * r_d) / stone["feret"]
    return (stone["volume"] * s ** 3 + stone["area"] * s * s * r_d + stone["curvature"] * s * r_d * r_d
            + 4.0 / 3.0 * math.pi * r_d ** 3)


def mean_stone_volume(scene, samples=20000):
    """Mean dilated volume of the gradation over the library shapes [m^3] (a fixed-seed sample)."""
    rng = np.random.default_rng(12345)
    sizes = sample_sizes(scene["gradation"], rng, samples)
    shapes = rng.integers(len(templates(scene)), size=samples)
    return float(np.mean([stone_volume(scene, s, d) for s, d in zip(shapes, sizes)]))


# The stones as sphere clusters (particle_shape = "cluster": cluster_engine.py).
# The scale of a cluster in its dilated polyhedron is found by bisection to this fraction of the stone's size.
CONTAINMENT_TOLERANCE = 1e-6

_CLUSTER_TEMPLATES = {}


def _sphere_in_dilated(normals, offsets, core, centre, radius, dilation):
    """Whether the ball (centre, radius) lies in core + ball(dilation), the core convex with face planes n.x <= d:
    for radius > dilation iff the centre lies at least radius - dilation inside every face plane (the exact inner
    distance of a convex polytope), else iff its distance to the core (non-negative least squares over convex
    combinations of the vertices; Lawson & Hanson 1974 ch. 23) is at most dilation - radius."""
    inside = float(np.min(offsets - normals @ centre))
    if radius > dilation:
        return inside >= radius - dilation
    if inside >= 0.0:
        return True
    from scipy.optimize import nnls
    weight = 1e6
    weights, _ = nnls(np.vstack([core.T, weight * np.ones(len(core))]), np.concatenate([centre, [weight]]))
    return float(np.linalg.norm(core.T @ weights - centre)) <= dilation - radius


def cluster_templates(level, fraction):
    """Per library stone: {spheres (n, 4) in the stone's frame at unit size, volume and principal inertia per unit
    density at that size}. The cluster is scaled to the hull whose largest extent is the stone's size, and shrunk
    where needed (bisection to CONTAINMENT_TOLERANCE; by at most 1.3 % on the library at fraction 0.1) so that every
    member lies inside the dilated polyhedron of that size (core x (1 - 2 fraction), plus r_d = fraction x size): a
    cluster put in place of a polyhedron of the bed touches nothing the polyhedron did not."""
    key = (level, fraction)
    if key in _CLUSTER_TEMPLATES:
        return _CLUSTER_TEMPLATES[key]
    templates = []
    for stone in library():
        cluster = stone["clusters"][level]
        spheres = np.asarray(cluster["spheres"], float) / stone["feret"]
        core = np.asarray(stone["vertices"], float) / stone["feret"] * (1.0 - 2.0 * fraction)
        polytope = ballast_clusters.ConvexStone(core, stone["triangles"])

        def fits(scale):
            return all(_sphere_in_dilated(polytope.planeNormals, polytope.planeOffsets, core, scale * s[:3],
                                          scale * s[3], fraction) for s in spheres)
        low, high = 0.0, 1.0
        if fits(1.0):
            low = 1.0
        while high - low > CONTAINMENT_TOLERANCE:
            middle = 0.5 * (low + high)
            low, high = (middle, high) if fits(middle) else (low, middle)
        templates.append({"spheres": spheres * low, "volume": cluster["volume"] / stone["feret"] ** 3 * low ** 3,
                          "inertia": np.asarray(cluster["principalInertia"], float) / stone["feret"] ** 5 * low ** 5,
                          "scale": low})
    _CLUSTER_TEMPLATES[key] = templates
    return templates


def cluster_of(scene, level, shape, size):
    """(member spheres (n, 4) in the stone's frame [m], mass [kg], principal inertia [kg m^2]) of library stone
    `shape` at characteristic length `size`, inside its dilated polyhedron (cluster_templates)."""
    t = cluster_templates(level, scene["dilation_fraction"])[shape]
    density = scene["material"]["density"]
    return t["spheres"] * size, density * t["volume"] * size ** 3, density * t["inertia"] * size ** 5


# ---------------------------------------------------------------------------------------------------
# Gradation: the characteristic length of Ullrich 2022 §6.2, normal (truncated) or piece-wise constant.
# ---------------------------------------------------------------------------------------------------
def sample_sizes(gradation, rng, count):
    """`count` characteristic lengths [m] drawn from the gradation, rounded to SIZE_QUANTUM of its mean so that
    stones share shape templates: "normal": the normal distribution (mean, std) truncated to [min, max] (rejection);
    "piecewise": a piece-wise constant density, bin k of [edges[k], edges[k+1]] with number fraction fractions[k]
    (the bin by inversion of the cumulative fractions, then uniform in it)."""
    low, high = gradation["min"], gradation["max"]
    if gradation["distribution"] == "piecewise":
        edges = np.asarray(gradation["edges"])
        cumulative = np.cumsum(gradation["fractions"])
        bins = np.minimum(np.searchsorted(cumulative / cumulative[-1], rng.random(count), side="right"),
                          len(edges) - 2)
        sizes = edges[bins] + rng.random(count) * (edges[bins + 1] - edges[bins])
    else:
        mean, std = gradation["mean"], gradation["std"]
        sizes = np.empty(0)
        while len(sizes) < count:
            draw = rng.normal(mean, std, size=2 * (count - len(sizes)) + 16)
            sizes = np.concatenate([sizes, draw[(draw >= low) & (draw <= high)]])
    quantum = SIZE_QUANTUM * gradation["mean"]
    return np.clip(np.round(sizes[:count] / quantum) * quantum, low, high)


def gradation_of(p, scale):
    """The gradation of p with every length times `scale`: {distribution, mean, std, min, max} and for "piecewise"
    {edges, fractions}, whose mean and std are the piece-wise constant density's (uniform in each bin)."""
    if p["size_distribution"] != "piecewise":
        return {"distribution": "normal", **{k: scale * p[f"stone_size_{k}_m"] for k in ("mean", "std", "min", "max")}}
    edges = scale * np.asarray(p["stone_size_edges_m"], float)
    fractions = np.asarray(p["stone_size_fractions"], float) / math.fsum(p["stone_size_fractions"])
    low, high = edges[:-1], edges[1:]
    mean = float(np.sum(fractions * (low + high) / 2))
    second = float(np.sum(fractions * (low * low + low * high + high * high) / 3))
    return {"distribution": "piecewise", "mean": mean, "std": math.sqrt(max(0.0, second - mean * mean)),
            "min": float(edges[0]), "max": float(edges[-1]), "edges": edges.tolist(), "fractions": fractions.tolist()}


def seed_stone_count(p):
    """Stones of the seed's gradation (unscaled) of the library's own hulls that fill this bed at ASSUMED_POROSITY:
    the reference of size_scale, the same for every triangles_per_stone, so that a resolution study keeps the sizes
    (reduced stones are smaller at the same characteristic length: more of them fill the bed)."""
    scene = _scene_with_scale({**p, "triangles_per_stone": 0}, 1.0)
    return (1.0 - ASSUMED_POROSITY) * math.prod(scene["bed"]) / mean_stone_volume(scene)


def size_scale(p):
    """Factor on every length of the gradation: (seed count / stones)^(1/3), so that about `stones` stones fill
    the bed; 1 (the seed's sizes) when stones = 0."""
    if p["stones"] <= 0:
        return 1.0
    return (seed_stone_count(p) / p["stones"]) ** (1.0 / 3.0)


# ---------------------------------------------------------------------------------------------------
# The scene
# ---------------------------------------------------------------------------------------------------
def _scene_with_scale(p, scale):
    length, width = p["bed_length_m"], p["bed_width_m"]
    gradation = gradation_of(p, scale)
    centre = (0.5 * length, 0.5 * width)
    height = p["bed_height_m"]
    sensor_top = height - p["sensor_depth_m"]
    sensors = [(centre[0] + (k - SENSOR_COUNT // 2) * SENSOR_SPACING, centre[1], sensor_top - 0.5 * SENSOR_SIZE[2])
               for k in range(SENSOR_COUNT)]
    return {
        "bed": (length, width, height),
        "centre": centre,
        "gradation": gradation,
        "size_scale": scale,
        "dilation_fraction": p["dilation_fraction"],
        "triangles_per_stone": p["triangles_per_stone"],
        "particle_shape": p["particle_shape"],
        "material": {"density": p["particle_density"], "young": p["particle_young"], "poisson": p["particle_poisson"],
                     "friction": p["friction"], "restitution": p["restitution"]},
        "sleeper": {"size": SLEEPER_SIZE, "origin": (centre[0] - 0.5 * SLEEPER_SIZE[0], centre[1] - 0.5 * SLEEPER_SIZE[1]),
                    "rail_seats": (centre[0] - RAIL_SEAT_OFFSET, centre[0] + RAIL_SEAT_OFFSET),
                    "rail_seat_size": RAIL_SEAT_SIZE},
        "sensors": {"size": SENSOR_SIZE, "centres": sensors, "top": sensor_top,
                    "dilation": p["sensor_dilation_m"]},
        # Stage heights (Ullrich 2022 Fig. 6.4): the first layer is trimmed where the sensors' bottoms go.
        "first_trim": sensor_top - SENSOR_SIZE[2],
        "final_trim": height,
    }


def build(p):
    """The scene of a case's parameters p (flat dict): box, gradation (scaled by size_scale), materials, sleeper,
    sensors, stage heights, preparation stages and load pattern."""
    scene = _scene_with_scale(p, size_scale(p))
    scene["stages"] = preparation_stages(p, scene)
    scene["load_pattern"] = load_pattern(p)
    return scene


def check(p):
    """Problems with a parameter set that ranges cannot express, one message each."""
    problems = []
    length, width = p["bed_length_m"], p["bed_width_m"]
    reach = SENSOR_COUNT // 2 * SENSOR_SPACING + 0.5 * SENSOR_SIZE[0]
    if length < SLEEPER_SIZE[0] + 0.1 or length < 2 * reach + 0.1:
        problems.append(f"bed_length_m={length:g}: the 2.5 m sleeper and the sensors (x = centre +- {reach:.2f} m) need "
                        f"at least {max(SLEEPER_SIZE[0], 2 * reach) + 0.1:.2f} m")
    if width < max(SLEEPER_SIZE[1], SENSOR_SIZE[1]) + 0.05:
        problems.append(f"bed_width_m={width:g}: the sleeper (0.2 m) and the sensors (0.22 m) need at least 0.27 m")
    if p["sensor_depth_m"] + SENSOR_SIZE[2] > p["bed_height_m"] - 0.1:
        problems.append(f"sensor_depth_m={p['sensor_depth_m']:g}: the sensors must lie above 0.1 m of ballast")
    if p["size_distribution"] == "piecewise":
        problems += _piecewise_problems(p["stone_size_edges_m"], p["stone_size_fractions"])
    elif not p["stone_size_min_m"] <= p["stone_size_mean_m"] <= p["stone_size_max_m"]:
        problems.append("stone sizes need stone_size_min_m <= stone_size_mean_m <= stone_size_max_m")
    if 0 < p["triangles_per_stone"] < 4:
        problems.append(f"triangles_per_stone={p['triangles_per_stone']}: a stone needs at least 4 triangles (a "
                        "tetrahedron), or 0 for the shape library's own hulls")
    elif p["triangles_per_stone"] % 2:
        problems.append(f"triangles_per_stone={p['triangles_per_stone']}: a closed convex triangulated surface has an "
                        f"even number of triangles (2V - 4 for V vertices); use {p['triangles_per_stone'] - 1} or "
                        f"{p['triangles_per_stone'] + 1}")
    if p["particle_shape"] == "cluster" and p["triangles_per_stone"]:
        problems.append(f"triangles_per_stone={p['triangles_per_stone']} with particle_shape='cluster': the clusters are "
                        "fitted inside the library's own hulls (cluster_templates); use triangles_per_stone=0")
    return problems


def _piecewise_problems(edges, fractions):
    """What is wrong with a piece-wise constant gradation's bins (edges [m]) and number fractions, one message each."""
    numbers = lambda values: all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                                 for v in values)
    if len(edges) < 2 or not numbers(edges) or edges[0] <= 0 or any(b <= a for a, b in zip(edges, edges[1:])):
        return [f"stone_size_edges_m={edges}: the bins' edges [m], at least two, positive and increasing"]
    if len(fractions) != len(edges) - 1 or not numbers(fractions):
        return [f"stone_size_fractions={fractions}: one number fraction per bin ({len(edges) - 1} for "
                f"{len(edges)} edges)"]
    if min(fractions) < 0 or abs(math.fsum(fractions) - 1.0) > 1e-6:
        return [f"stone_size_fractions={fractions}: number fractions, non-negative and summing to 1 "
                f"(sum {math.fsum(fractions):.6g})"]
    return []


# ---------------------------------------------------------------------------------------------------
# Stones of a layer and their start positions
# ---------------------------------------------------------------------------------------------------
def layer_stones(scene, rng, z_low, z_high):
    """[(shape index, size)] for a settled layer from z_low to z_high over the bed's footprint, at
    ASSUMED_POROSITY, shapes drawn uniformly from the library."""
    length, width, _ = scene["bed"]
    volume = (1.0 - ASSUMED_POROSITY) * length * width * (z_high - z_low)
    sizes = sample_sizes(scene["gradation"], rng, max(1, int(round(volume / mean_stone_volume(scene)))))
    shapes = rng.integers(len(templates(scene)), size=len(sizes))
    return list(zip(shapes.tolist(), sizes.tolist()))


# Quaternions (w, x, y, z) and rotation matrices (body frame to world): the shape library's helpers.
rotation_matrix = ballast_clusters.rotationFromQuaternions
_quaternion_of = ballast_clusters.quaternionFromRotation


def _column_profile(core, triangles, dilation, rotation, cell, margin):
    """Vertical extent of a rotated stone over a grid of columns: the core's face planes pushed out by r_d + margin
    (a convex superset of the dilated stone) cut each vertical line through a column centre. Returns (bottom,
    top) arrays (wx, wy) relative to the body origin (NaN where the column misses the stone) and the column
    offsets u (wx), v (wy) of the grid, centred on the body origin."""
    world = core @ rotation.T
    a, b, c = world[triangles[:, 0]], world[triangles[:, 1]], world[triangles[:, 2]]
    e, f = b - a, c - a  # (b - a) x (c - a), written out: np.cross's axis handling dominated this function's time
    normals = np.stack((e[:, 1] * f[:, 2] - e[:, 2] * f[:, 1], e[:, 2] * f[:, 0] - e[:, 0] * f[:, 2],
                        e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]), axis=1)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    offsets = np.einsum("ij,ij->i", normals, a) + dilation + margin
    reach = np.max(np.abs(world[:, :2]), axis=0) + dilation + margin
    wx, wy = 2 * int(math.ceil(reach[0] / cell)) + 1, 2 * int(math.ceil(reach[1] / cell)) + 1
    u, v = (np.arange(wx) - (wx - 1) / 2.0) * cell, (np.arange(wy) - (wy - 1) / 2.0) * cell
    x, y = u[:, None], v[None, :]
    # n_x x + n_y y + n_z z <= d for every face: bounds on z per column, upward faces bound it from above, downward
    # ones from below, vertical ones cut columns off (each group evaluated on its own faces only).
    nz = normals[:, 2]

    def rest(faces):
        return offsets[faces][None, None, :] - normals[faces, 0] * x[..., None] - normals[faces, 1] * y[..., None]

    up, down, side = nz > 1e-12, nz < -1e-12, np.abs(nz) <= 1e-12
    top = np.min(rest(up) / nz[up], axis=2) if up.any() else np.full((wx, wy), np.inf)
    bottom = np.max(rest(down) / nz[down], axis=2) if down.any() else np.full((wx, wy), -np.inf)
    outside = bottom > top
    if side.any():
        outside |= np.any(rest(side) < 0, axis=2)
    bottom[outside], top[outside] = np.nan, np.nan
    return bottom, top, u, v


def place_cloud(scene, stones, region, rng, gap_fraction=0.02, candidates=10, orientations_tried=4):
    """Start positions for `stones` [(shape, size)], none touching: each stone gets a random orientation
    (uniform, Shoemake) and is dropped, in random order, onto a height map of the region's footprint (columns of
    a tenth of the smallest size): its column profile (_column_profile, widened by gap_fraction x size and by most of
    a cell) comes to
    rest on the highest column under it, and of `orientations_tried` random orientations x `candidates` random
    (x, y) the lowest centre is kept (random sequential deposition that prefers stones lying low: a dense, mixed
    cloud above z_low, without the voids of box packing).
    region = (x_low, x_high, y_low, y_high, z_low). Returns {positions (n,3) of the body frames, orientations
    (n,4) w,x,y,z, top: the highest stone top}."""
    x_low, x_high, y_low, y_high, z_low = region
    cell = 0.1 * scene["gradation"]["min"]
    nx, ny = max(1, int((x_high - x_low) / cell)), max(1, int((y_high - y_low) / cell))
    heights = np.full((nx, ny), float(z_low))
    n = len(stones)
    positions, orientations = np.zeros((n, 3)), np.zeros((n, 4))
    top = z_low
    for i in rng.permutation(n):
        shape, size = stones[i]
        core, r_d = stone_core(scene, shape, size)
        best = None
        for attempt in itertools.count():
            # A stone that fitted in none of the orientations tried (a large one in a narrow bed) gets more, up to
            # MAX_ORIENTATIONS: the draws of every stone that fits in the first ones are those of fewer tries.
            if attempt >= orientations_tried and (best is not None or attempt >= MAX_ORIENTATIONS):
                break
            rotation = ballast_clusters.randomRotation(rng)
            # The margin covers the gap and what sampling the columns at their centres misses (up to a cell's
            # half-diagonal sideways): no two stones overlap.
            bottom, upper, _, _ = _column_profile(core, templates(scene)[shape]["triangles"], r_d, rotation, cell,
                                                  0.5 * gap_fraction * size + 0.75 * cell)
            wx, wy = bottom.shape
            # The candidates' corners, drawn as (ix, iy) pairs in turn (one call, the same stream as one draw each).
            corners = rng.integers(0, np.array([max(1, nx - wx + 1), max(1, ny - wy + 1)] * candidates))
            if wx > nx or wy > ny:
                continue  # the stone is wider than the region
            ix, iy = corners[0::2], corners[1::2]
            inside = ~np.isnan(bottom)
            # Every candidate's window at once: (candidates, wx, wy); its rest height is the highest column contact.
            windows = heights[ix[:, None, None] + np.arange(wx)[None, :, None], iy[:, None, None] + np.arange(wy)]
            rests = np.max((windows - bottom)[:, inside], axis=1)
            k = int(np.argmin(rests))  # the first of equal lowest, as a strict comparison in drawing order keeps
            if best is None or rests[k] < best[0]:
                best = (float(rests[k]), int(ix[k]), int(iy[k]), rotation, bottom, upper)
        if best is None:
            raise ValueError(f"place_cloud: a stone of size {size:.3f} m does not fit in the region {region} in "
                             f"{MAX_ORIENTATIONS} orientations: more stones (smaller ones) or a wider bed")
        centre_z, ix, iy, rotation, bottom, upper = best
        wx, wy = bottom.shape
        inside = ~np.isnan(bottom)
        window = heights[ix:ix + wx, iy:iy + wy]
        window[inside] = np.maximum(window[inside], centre_z + upper[inside])
        positions[i] = (x_low + (ix + 0.5 * wx) * cell, y_low + (iy + 0.5 * wy) * cell, centre_z)
        orientations[i] = _quaternion_of(rotation)
        top = max(top, centre_z + float(np.nanmax(upper)))
    return {"positions": positions, "orientations": orientations, "top": top}


def sensor_core(scene):
    """Core vertices of a sensor block (its box shrunk by the sensor's dilation on every side) and the dilation."""
    r = scene["sensors"]["dilation"]
    half = [0.5 * s - r for s in SENSOR_SIZE]
    return np.array([(sx * half[0], sy * half[1], sz * half[2]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]), r


# ---------------------------------------------------------------------------------------------------
# Preparation (Ullrich 2022 §6.2, Fig. 6.4) and the load pattern
# ---------------------------------------------------------------------------------------------------
def preparation_stages(p, scene):
    """The bed preparation as a list of stages {name, what, ...settings}; bed.py runs them in this order."""
    surplus = scene["gradation"]["mean"]  # generated above each trim height, so that the trimmed layer is full
    compaction = {"pressure_kpa": p["compaction_pressure_kPa"], "amplitude": p["compaction_amplitude"],
                  "frequency_hz": p["compaction_frequency_hz"], "cycles": p["compaction_cycles"]}
    return [
        {"name": "layer1", "what": "generate the first layer and let it settle", "z_low": 0.0,
         "z_high": scene["first_trim"] + surplus, "settle_s": p["settle_max_s"]},
        {"name": "compact1", "what": "compact it with a plate moving sinusoidally", **compaction},
        {"name": "trim1", "what": f"remove stones centred above {scene['first_trim']:.3f} m or inside a sensor; place "
                                  "the five sensors", "height": scene["first_trim"]},
        {"name": "layer2", "what": "generate the second layer on top and let it settle",
         "z_high": scene["final_trim"] + surplus, "settle_s": p["settle_max_s"]},
        {"name": "compact2", "what": "compact it with the plate", **compaction},
        {"name": "trim2", "what": f"remove stones centred above {scene['final_trim']:.3f} m and let the bed rest",
         "height": scene["final_trim"], "settle_s": p["trim_settle_s"]},
        {"name": "seat", "what": "lower a rigid plate of the sleeper's footprint onto the bed until it carries the "
                                 "sleeper's weight plus the seating load",
         "load_n": p["sleeper_density"] * math.prod(SLEEPER_SIZE) * GRAVITY + p["seating_load_N"]},
    ]


def design_contact_loads(p, scene, phase):
    """What the DEM time step is sized for (PolyhedraGpuEngine.criticalTimeStep x critical_step_fraction), for the
    "preparation" or the "load" run:
    - contact_force_n: 5 x the mean force of a stone under the plate (compaction: its peak pressure) or the sleeper
      (load: the peak load plus the sleeper's weight over 2.5 x 0.2 m), the mean being the pressure times the mean
      stone size squared (one contact per stone under a flat face); a granular force network's forces fall off
      exponentially above the mean, and 5x the mean is exceeded by a few contacts in a thousand (Mueth, Jaeger &
      Nagel 1998);
    - impact_speed_m_s: preparation: a stone falling through twice the bed height (the generated cloud's top); load
      run: the sleeper's largest speed, that of a bounce on the bed (taken as 0.5 m/s)."""
    if phase == "preparation":
        pressure = (1.0 + p["compaction_amplitude"]) * p["compaction_pressure_kPa"] * 1e3
        speed = math.sqrt(2.0 * GRAVITY * 2.0 * p["bed_height_m"])
    else:
        weight = p["sleeper_density"] * math.prod(SLEEPER_SIZE) * GRAVITY
        pressure = (p["peak_load_kN"] * 1e3 + weight) / (SLEEPER_SIZE[0] * SLEEPER_SIZE[1])
        speed = 0.5
    return {"contact_force_n": 5.0 * pressure * scene["gradation"]["mean"] ** 2, "impact_speed_m_s": speed}


def load_pattern(p):
    """The rail-seat load history as the FEM options of freefem_scripts/lib/load_pattern.idp: loads are the
    total on the sleeper [N], half per rail seat; times in the test's own time, run time_scale times faster."""
    return {"seatingLoad": p["seating_load_N"], "seatingTime": p["seating_time_s"], "rampRate": p["ramp_rate_kN_s"] * 1e3,
            "peakLoad": p["peak_load_kN"] * 1e3, "holdTime": p["hold_time_s"],
            "cyclicMinLoad": p["cyclic_min_kN"] * 1e3, "cyclicMaxLoad": p["cyclic_max_kN"] * 1e3,
            "cyclicFrequency": p["cyclic_frequency_hz"], "cycles": p["cycles"], "timeScale": p["time_scale"]}


def load_run_duration(p):
    """Simulated time of the coupled load run [s]: the pattern's end and the rest after it (settle_after_s)."""
    return pattern_phase_ends(load_pattern(p))["patternEnd"] + p["settle_after_s"]


def pattern_phase_ends(pattern):
    """Ends of the pattern's phases in simulated seconds, as loadPatternPhaseEnds of load_pattern.idp computes
    them (the run's fem_summary.json holds FreeFEM's own values; the case checks that they agree):
    rampStart, holdStart, holdEnd, cyclesStart, cyclesEnd, patternEnd."""
    rate = pattern["rampRate"]
    ends = [pattern["seatingTime"]]
    ends.append(ends[-1] + (pattern["peakLoad"] - pattern["seatingLoad"]) / rate)
    ends.append(ends[-1] + pattern["holdTime"])
    ends.append(ends[-1] + (pattern["peakLoad"] - pattern["cyclicMinLoad"]) / rate)
    ends.append(ends[-1] + pattern["cycles"] / pattern["cyclicFrequency"])
    ends.append(ends[-1] + (pattern["peakLoad"] - pattern["cyclicMinLoad"]) / rate)
    names = ("rampStart", "holdStart", "holdEnd", "cyclesStart", "cyclesEnd", "patternEnd")
    return {name: end / pattern["timeScale"] for name, end in zip(names, ends)}


# ---------------------------------------------------------------------------------------------------
# The bed file: what defines a bed, and where it is kept
# ---------------------------------------------------------------------------------------------------
BED_PARAMETERS = ("bed_length_m", "bed_width_m", "bed_height_m", "sensor_depth_m", "particle_shape", "stones", "stone_size_mean_m",
                  "stone_size_std_m", "stone_size_min_m", "stone_size_max_m", "dilation_fraction", "particle_density",
                  "particle_young", "particle_poisson", "friction", "restitution", "sensor_dilation_m",
                  "compaction_pressure_kPa", "compaction_amplitude", "compaction_frequency_hz", "compaction_cycles",
                  "settle_max_s", "settle_speed_m_s", "trim_settle_s", "sleeper_density", "seating_load_N",
                  "critical_step_fraction", "cluster_level", "seed")
# Bed parameters added after beds were first cached, each with the value every bed made before it existed was made
# with: such a parameter enters the key only when it differs from that value, so that the beds cached before it (CI
# keeps its bed cache between runs) keep their keys. These values are history: never change them.
ADDED_BED_PARAMETERS = {"triangles_per_stone": 0, "size_distribution": "normal"}
# The bins of a piece-wise constant gradation: in the key of the beds drawn from it (size_distribution = "piecewise").
PIECEWISE_PARAMETERS = ("stone_size_edges_m", "stone_size_fractions")


def bed_key(p):
    """Cache key of a bed: a hash of bed_values(p)."""
    return bedcache.key(bed_values(p))


def bed_values(p):
    """What defines a bed: the file layout (BED_FORMAT; a cluster bed's CLUSTER_BED_FORMAT), the parameters of
    BED_PARAMETERS, those of ADDED_BED_PARAMETERS that differ from their value before they existed, a piece-wise
    gradation's bins, and the preparation code's version (PREPARATION_VERSION, from 2 on)."""
    values = {"format": BED_FORMAT, **{name: p[name] for name in BED_PARAMETERS}}
    if p["particle_shape"] == "cluster":
        values["cluster_format"] = CLUSTER_BED_FORMAT
    values.update({name: p[name] for name, before in ADDED_BED_PARAMETERS.items() if p[name] != before})
    if p["size_distribution"] == "piecewise":
        values.update({name: p[name] for name in PIECEWISE_PARAMETERS})
    if PREPARATION_VERSION != 1:
        values["preparation"] = PREPARATION_VERSION
    return values


def bed_parameters(p):
    """The parameters of p that define its bed (BED_PARAMETERS and ADDED_BED_PARAMETERS), as the bed file records them."""
    return {name: p[name] for name in BED_PARAMETERS + tuple(ADDED_BED_PARAMETERS) + PIECEWISE_PARAMETERS}


def bed_path(p):
    """Where the bed of these parameters is kept: bed_cache_dir (default $RAILCOSIM_CACHE/beds/sleeper_on_ballast)."""
    return bedcache.path("sleeper_on_ballast", bed_values(p), suffix=".h5", folder=p["bed_cache_dir"])


def describe(p):
    """A few lines on the scene of p: sizes, expected stone count, stages, pattern duration."""
    scene = build(p)
    g = scene["gradation"]
    count = (1.0 - ASSUMED_POROSITY) * math.prod(scene["bed"]) / mean_stone_volume(scene)
    ends = pattern_phase_ends(scene["load_pattern"])
    bins = (" (bins " + ", ".join(f"{a:.4f}-{b:.4f}: {f:.3f}" for a, b, f in zip(g["edges"], g["edges"][1:], g["fractions"]))
            + ")") if g["distribution"] == "piecewise" else ""
    lines = [f"bed {scene['bed'][0]:g} x {scene['bed'][1]:g} x {scene['bed'][2]:g} m, stones: {g['distribution']}{bins} mean {g['mean']:.4f} m, "
             f"std {g['std']:.4f} m in [{g['min']:.4f}, {g['max']:.4f}] (x{scene['size_scale']:.3f} of the seed's), "
             f"r_d = {scene['dilation_fraction']:g} x size; about {count:.0f} stones at porosity {ASSUMED_POROSITY:g} "
             f"(seed's sizes: {seed_stone_count(p):.0f})",
             "stone templates: " + ", ".join(f"{t['name']} {len(t['triangles'])}" for t in templates(scene)) + " triangles "
             + (f"(at most {scene['triangles_per_stone']})" if scene["triangles_per_stone"] else "(the library's hulls)"),
             f"sensors: top at z = {scene['sensors']['top']:.3f} m, x = "
             + ", ".join(f"{c[0]:.3f}" for c in scene["sensors"]["centres"]),
             "stages: " + "; ".join(f"{s['name']}: {s['what']}" for s in scene["stages"]),
             f"load pattern: {ends['patternEnd']:.4f} s simulated (ramp 1 from {ends['rampStart']:.4f} s, hold "
             f"{ends['holdStart']:.4f}-{ends['holdEnd']:.4f} s, cycles {ends['cyclesStart']:.4f}-{ends['cyclesEnd']:.4f} s)"]
    return "\n".join(lines)


if __name__ == "__main__":
    # /usr/bin/python3 cases/sleeper_on_ballast/scene.py [--set name=value ...]: the scene of case.toml's defaults.
    sys.path.insert(0, os.path.join(ROOT, "python"))
    import tomllib
    from railcosim import parameters
    with open(os.path.join(HERE, "case.toml"), "rb") as f:
        config = tomllib.load(f)
    sets = [a for a in sys.argv[1:] if a != "--set"]
    print(describe(parameters.resolve_parameters(config, "--smoke" in sets, [s for s in sets if s != "--smoke"])))
