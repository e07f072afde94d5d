"""The sleeper-on-ballast scene without a DEM run (cases/sleeper_on_ballast/scene.py): the stone templates of a
particle resolution (triangles_per_stone) against the geometry a convex polyhedron must obey, and the bed cache key."""
import itertools
import math
import os
import sys
import tomllib
import unittest

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
CASE = os.path.join(ROOT, "cases", "sleeper_on_ballast")
sys.path[:0] = [CASE, os.path.join(ROOT, "python")]
import scene as sc  # noqa: E402
from railcosim import parameters  # noqa: E402

with open(os.path.join(CASE, "case.toml"), "rb") as handle:
    CONFIG = tomllib.load(handle)


def case_parameters(*sets, smoke=False):
    return parameters.resolve_parameters(CONFIG, smoke, list(sets))


def face_planes(vertices, triangles):
    """Unit outward normals and offsets of the triangles' planes (n . x = d), from the corners alone."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    return normals, np.einsum("ij,ij->i", normals, a)


def enclosed_volume(vertices, triangles):
    """Volume enclosed by a closed outward-oriented triangulated surface (divergence theorem: the signed tetrahedra
    from the origin, sum of a . (b x c) / 6); negative if the triangles face inward."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0


def feret(points):
    return max(float(np.linalg.norm(p - q)) for p, q in itertools.combinations(points, 2))


# Library hulls: 12 to 66 triangles; the resolutions tried: every even count from 4 to 70.
RESOLUTIONS = list(range(4, 72, 2))
# Round-off of a plane test on coordinates of order 1 (unit sieve size): a normal from one cross product and a dot
# product carry a few 1e-16; 1e-12 is far below any real protrusion (the library's vertices lie 1e-3 and more off
# each other's planes).
ROUNDOFF = 1e-12


class StoneTemplatesTest(unittest.TestCase):
    """scene.library(N): each library stone as a convex hull of at most N triangles (triangles_per_stone)."""

    def test_euler_relation_and_closed_surface(self):
        """A closed triangulated surface of genus 0 obeys V - E + F = 2 with every edge in exactly two triangles
        (Euler), so F = 2V - 4; and never more triangles than asked."""
        for n in RESOLUTIONS:
            for stone in sc.library(n):
                triangles = stone["triangles"]
                used = np.unique(triangles)
                edges = {}
                for t in triangles:
                    for k in range(3):
                        edge = tuple(sorted((int(t[k]), int(t[(k + 1) % 3]))))
                        edges[edge] = edges.get(edge, 0) + 1
                with self.subTest(n=n, shape=stone["name"]):
                    self.assertEqual(len(used), len(stone["vertices"]), "every vertex is a vertex of the surface")
                    self.assertEqual(set(edges.values()), {2}, "every edge in exactly two triangles")
                    self.assertEqual(len(used) - len(edges) + len(triangles), 2)
                    self.assertLessEqual(len(triangles), n)

    def test_convex_and_inside_the_library_hull(self):
        """Every vertex on the inner side of every face plane (convex, faces outward), and every vertex of the
        reduced hull inside the library stone's hull (a convex hull of points inside a convex body lies inside
        it), both within ROUNDOFF."""
        for n in RESOLUTIONS:
            for stone, original in zip(sc.library(n), sc.library(0)):
                v = stone["vertices"]
                with self.subTest(n=n, shape=stone["name"]):
                    normals, offsets = face_planes(v, stone["triangles"])
                    self.assertLessEqual(float(np.max(v @ normals.T - offsets)), ROUNDOFF)
                    normals, offsets = face_planes(original["vertices"], original["triangles"])
                    self.assertLessEqual(float(np.max(v @ normals.T - offsets)), ROUNDOFF)

    def test_volume_loss_monotone(self):
        """Fewer triangles never keep more volume: greedy removal makes each hull a subset of the next finer one
        (enclosed volume by the divergence theorem, positive: the faces point outward). Coarsest is a tetrahedron."""
        for shape in range(len(sc.library(0))):
            volumes = [enclosed_volume(sc.library(n)[shape]["vertices"], sc.library(n)[shape]["triangles"])
                       for n in RESOLUTIONS]
            full = enclosed_volume(sc.library(0)[shape]["vertices"], sc.library(0)[shape]["triangles"])
            with self.subTest(shape=sc.library(0)[shape]["name"]):
                self.assertGreater(volumes[0], 0.0)
                self.assertEqual(len(sc.library(4)[shape]["vertices"]), 4)
                # The same volume computed twice in different orders differs by round-off only: 1e-12 relative.
                self.assertTrue(all(b >= a * (1 - 1e-12) for a, b in zip(volumes, volumes[1:])), volumes)
                self.assertLessEqual(volumes[-1], full * (1 + 1e-12))

    def test_library_hull_kept_at_or_above_its_count(self):
        """N at or above a stone's own triangle count keeps its hull, vertex for vertex."""
        for n in RESOLUTIONS:
            for stone, original in zip(sc.library(n), sc.library(0)):
                if len(original["triangles"]) <= n:
                    with self.subTest(n=n, shape=stone["name"]):
                        self.assertTrue(np.array_equal(stone["vertices"], original["vertices"]))
                        self.assertTrue(np.array_equal(stone["triangles"], original["triangles"]))

    def test_characteristic_length_kept(self):
        """The dilated stone's largest extent (the characteristic length the gradation draws) is the size asked for
        at every resolution: core Feret diameter (all vertex pairs) + 2 r_d; round-off 1e-12 of the size."""
        for n in (0, 4, 10, 30):
            scene = sc.build(case_parameters(f"triangles_per_stone={n}"))
            for shape in range(len(sc.templates(scene))):
                core, r_d = sc.stone_core(scene, shape, 0.07)
                with self.subTest(n=n, shape=shape):
                    self.assertAlmostEqual(feret(core) + 2 * r_d, 0.07, delta=1e-12 * 0.07)

    def test_parameter_refused(self):
        """Odd, negative and too small resolutions are refused before any run, with the reason."""
        for value, words in ((3, "at least 4"), (2, "at least 4"), (31, "even"), (-2, ">= 0")):
            p = case_parameters(f"triangles_per_stone={value}")
            problems = parameters.check_parameters(p, CONFIG) + sc.check(p)
            with self.subTest(value=value):
                self.assertEqual(len(problems), 1, problems)
                self.assertIn(words, problems[0])
        self.assertEqual(sc.check(case_parameters("triangles_per_stone=30")), [])


def piecewise_cdf(edges, fractions):
    """Cumulative distribution of a piece-wise constant density: number fraction f_k spread evenly over bin k."""
    edges, fractions = np.asarray(edges, float), np.asarray(fractions, float)

    def cdf(x):
        return float(np.sum(fractions * np.clip((x - edges[:-1]) / (edges[1:] - edges[:-1]), 0.0, 1.0)))
    return cdf


def truncated_normal_cdf(mean, std, low, high):
    phi = lambda x: 0.5 * (1.0 + math.erf((x - mean) / (std * math.sqrt(2.0))))
    return lambda x: (phi(min(max(x, low), high)) - phi(low)) / (phi(high) - phi(low))


# The porosity of the seed's scene measured over five packings (README, "On the GPU machine": 0.3921 +- 0.0007, the
# sensors' volume counted as solid) and their stone counts, 93,159-93,996.
SEED_POROSITY = 0.3921
SEED_COUNTS = (93159, 93996)
SENSORS_VOLUME = sc.SENSOR_COUNT * math.prod(sc.SENSOR_SIZE)


def mean_stone_volume(p):
    """Mean volume [m^3] of a stone of the unscaled gradation of p, in closed form: k_s E[d^3] averaged over the
    shapes (a dilated stone's volume is k_s d^3 for its characteristic length d: r_d and the core both scale with d).
    E[d^3]: the sum of f_k (b^4 - a^4) / (4 (b - a)) over the bins (uniform in each), or the truncated normal's third
    moment by quadrature (2e4 intervals of 3e-6 m: exact to 1e-8)."""
    scene = sc.build({**p, "stones": 0})
    k = np.mean([sc.stone_volume(scene, s, 1.0) for s in range(len(sc.templates(scene)))])
    if p["size_distribution"] == "piecewise":
        a, b = np.array(p["stone_size_edges_m"][:-1]), np.array(p["stone_size_edges_m"][1:])
        third = float(np.sum(np.array(p["stone_size_fractions"]) * (b ** 4 - a ** 4) / (4 * (b - a))))
    else:
        mean, std, low, high = (p[f"stone_size_{n}_m"] for n in ("mean", "std", "min", "max"))
        x = np.linspace(low, high, 20001)
        density = np.exp(-0.5 * ((x - mean) / std) ** 2)
        third = float(np.trapz(density * x ** 3, x) / np.trapz(density, x))
    return k * third


def full_box_count(p, porosity):
    """Stones of the unscaled gradation of p in the full 3.2 x 1.0 x 0.8 m box with its five sensors: the solid
    volume (1 - porosity) V_box - V_sensors over the mean stone volume."""
    return ((1.0 - porosity) * math.prod(sc.SEED_BED) - SENSORS_VOLUME) / mean_stone_volume(p)


class GradationTest(unittest.TestCase):
    """scene.sample_sizes and the stone counts of the two gradations (size_distribution)."""

    def test_sampler_against_the_density(self):
        """Pearson's chi-square of 200,000 drawn sizes against the exact probability of each size the sampler can
        return: a size is rounded to the nearest multiple of q (SIZE_QUANTUM x the gradation's mean) and clipped to
        [min, max], so size k q has the probability F((k + 1/2) q) - F((k - 1/2) q) of the density's cumulative F
        (the ends cut at min and max). Cells merged to at least 20 expected draws. Limit: the chi-square quantile
        1 - 1e-4, so that a right sampler fails with probability 1e-4 for a random seed (the seed is fixed here)."""
        from scipy import stats
        for distribution in ("piecewise", "normal"):
            p = case_parameters("stones=0", f"size_distribution={distribution}")
            g = sc.build(p)["gradation"]
            if distribution == "piecewise":
                cdf = piecewise_cdf(p["stone_size_edges_m"], p["stone_size_fractions"])
            else:
                cdf = truncated_normal_cdf(*(p[f"stone_size_{n}_m"] for n in ("mean", "std", "min", "max")))
            count = 200000
            sizes = sc.sample_sizes(g, np.random.default_rng(7), count)
            q = sc.SIZE_QUANTUM * g["mean"]
            low, high = g["min"], g["max"]
            first, last = int(round(low / q)), int(round(high / q))
            expected = np.array([cdf(min((k + 0.5) * q, high)) - cdf(max((k - 0.5) * q, low))
                                 for k in range(first, last + 1)]) * count
            observed = np.bincount(np.round(sizes / q).astype(int) - first, minlength=len(expected))
            self.assertEqual(len(observed), len(expected), "no size outside [min, max]")
            cells, e_sum, o_sum = [], 0.0, 0
            for e, o in zip(expected, observed):
                e_sum, o_sum = e_sum + e, o_sum + o
                if e_sum >= 20:
                    cells.append((e_sum, o_sum))
                    e_sum, o_sum = 0.0, 0
            if e_sum > 0:
                cells[-1] = (cells[-1][0] + e_sum, cells[-1][1] + o_sum)
            chi2 = sum((o - e) ** 2 / e for e, o in cells)
            limit = stats.chi2.ppf(1 - 1e-4, len(cells) - 1)
            with self.subTest(distribution=distribution, cells=len(cells)):
                self.assertAlmostEqual(sum(e for e, _ in cells), count, delta=1e-6 * count)
                self.assertLess(chi2, limit)

    def test_closed_form_count_against_the_seed_scale_beds(self):
        """The closed-form count of the normal gradation in the full box at the measured porosity against the five
        packings' counts (93,159-93,996): within 2 % of their mean. The packings' own counts scatter by 0.9 %, and the
        bed keeps its stones by position (trims, the sensors' boxes), not as a draw of the gradation."""
        count = full_box_count(case_parameters(), SEED_POROSITY)
        self.assertAlmostEqual(count / np.mean(SEED_COUNTS), 1.0, delta=0.02)

    def test_piecewise_fills_the_box_with_300000_stones(self):
        """Ullrich 2022 §6.6: the piece-wise constant gradation gave 300,000 stones in the 3.2 x 1.0 x 0.8 m box.
        The closed form (validated against the seed-scale beds above) at the measured porosity: within 5 % of it, the
        rounding of the thesis's figure (a round 300,000 in text and Table 6.2)."""
        count = full_box_count(case_parameters("size_distribution=piecewise"), SEED_POROSITY)
        self.assertAlmostEqual(count / 300000, 1.0, delta=0.05)

    def test_stones_scaling_per_distribution(self):
        """`stones = N` scales each gradation by its own unscaled count: the closed-form count of the scaled
        gradation in the default slice at scene.ASSUMED_POROSITY, (1 - porosity) V / (s^3 mean stone volume), is N.
        Tolerance 2 %: the scaling's reference count is a 20,000-draw sample mean of the stone volume (relative
        standard error below 0.6 %)."""
        for distribution in ("normal", "piecewise"):
            for stones in (500, 3000, 12000):
                p = case_parameters(f"stones={stones}", f"size_distribution={distribution}")
                scale = sc.build(p)["size_scale"]
                box = p["bed_length_m"] * p["bed_width_m"] * p["bed_height_m"]
                with self.subTest(distribution=distribution, stones=stones):
                    expected = (1 - sc.ASSUMED_POROSITY) * box / (scale ** 3 * mean_stone_volume(p))
                    self.assertAlmostEqual(expected / stones, 1.0, delta=0.02)
            self.assertEqual(sc.build(case_parameters("stones=0", f"size_distribution={distribution}"))["size_scale"], 1.0)

    def test_large_stones_placed_inside_a_narrow_bed(self):
        """The piece-wise gradation at smoke size draws stones up to 0.34 m across for a 0.3 m wide bed: each is placed
        (scene.place_cloud tries more orientations for a stone that fits in none of the first), every dilated stone
        inside the box's walls (rotated core's extent + r_d), none below the floor."""
        p = case_parameters("size_distribution=piecewise", smoke=True)
        scene = sc.build(p)
        rng = np.random.default_rng(p["seed"])
        stones = sc.layer_stones(scene, rng, 0.0, scene["stages"][0]["z_high"])
        self.assertGreater(max(size for _, size in stones), p["bed_width_m"])
        cloud = sc.place_cloud(scene, stones, (0.0, p["bed_length_m"], 0.0, p["bed_width_m"], 1e-3), rng)
        for (shape, size), position, orientation in zip(stones, cloud["positions"], cloud["orientations"]):
            core, r_d = sc.stone_core(scene, shape, size)
            world = core @ sc.rotation_matrix(orientation).T + position
            low, high = world.min(axis=0) - r_d, world.max(axis=0) + r_d
            self.assertTrue(low[0] >= 0 and low[1] >= 0 and low[2] >= 1e-3 and high[0] <= p["bed_length_m"]
                            and high[1] <= p["bed_width_m"], (size, low, high))

    def test_parameters_refused(self):
        """Bins that do not increase, fractions that do not match the bins or do not sum to 1: refused, with the
        reason; lists are given to --set as comma-separated values."""
        bad = (("stone_size_edges_m=0.02,0.01,0.08", "increasing"),
               ("stone_size_fractions=0.5,0.5", "one number fraction per bin"),
               ("stone_size_fractions=0.6,0.2,0.1,0.05,0.03,0.03", "summing to 1"),
               ("stone_size_fractions=1.1,-0.1,0,0,0,0", "non-negative"))
        for word, reason in bad:
            p = case_parameters("size_distribution=piecewise", word)
            problems = parameters.check_parameters(p, CONFIG) + sc.check(p)
            with self.subTest(word=word):
                self.assertEqual(len(problems), 1, problems)
                self.assertIn(reason, problems[0])
        p = case_parameters("size_distribution=piecewise", "stone_size_edges_m=[0.02, 0.04, 0.08]",
                            "stone_size_fractions=0.75,0.25")
        self.assertEqual(p["stone_size_edges_m"], [0.02, 0.04, 0.08])
        self.assertEqual(parameters.check_parameters(p, CONFIG) + sc.check(p), [])


class TemplateMassTest(unittest.TestCase):
    """The polyhedra library's own mass of the reduced stones (its integration of the dilated polyhedron) against the
    Steiner volume the scene sizes the bed with (scene.stone_volume), at every resolution: one stone of each template
    and size class handed to the standalone driver (railcosim.polyhedra_driver, the CPU reference)."""

    def test_library_mass_is_the_steiner_volume(self):
        """Relative tolerance 1e-6: the library integrates the dilated volume exactly up to round-off (the Steiner
        formula is exact for a convex core); what differs is the order of the sums."""
        from railcosim.polyhedra_driver import PolyhedraBed
        for n in (4, 10, 20, 30, 0):
            p = case_parameters(f"triangles_per_stone={n}", "polyhedra_backend=cpu", smoke=True)
            scene = sc.build(p)
            shapes = range(len(sc.templates(scene)))
            sizes = (scene["gradation"]["min"], scene["gradation"]["max"])
            engine = PolyhedraBed(1e-6, (1e10, 0.27, 0.2, 0.6), backend="cpu")
            for k, (shape, size) in enumerate(itertools.product(shapes, sizes)):
                core, r_d = sc.stone_core(scene, shape, size)
                engine.add_stone(core, r_d, p["particle_density"], (0.5 * k, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0))
            engine.set_walls(np.array([[(0, 0, 0), (10, 0, 0), (0, 10, 0)]], float), np.zeros(1, np.int32),
                             [(1e10, 0.27, 0.2, 0.0)])
            engine.initialize()
            masses = engine.states()[4]
            steiner = np.array([sc.stone_volume(scene, shape, size) * p["particle_density"]
                                for shape, size in itertools.product(shapes, sizes)])
            with self.subTest(n=n):
                np.testing.assert_allclose(masses, steiner, rtol=1e-6)


class BedKeyTest(unittest.TestCase):
    """scene.bed_key: a new parameter at the value every earlier bed was made with keeps the earlier beds' keys."""

    # Keys of beds cached before triangles_per_stone, size_distribution and PREPARATION_VERSION existed (the default
    # and the --smoke parameters): their files are in the bed caches of the desk and of CI; a key that changes would
    # prepare them again (106 s for the smoke bed, 16 min for the default one on 2 cores) while the bed they hold is
    # the same.
    KEYS = {False: "59ef077616443c1b", True: "52df4b31404f9603"}

    def test_keys_of_earlier_beds_kept(self):
        for smoke, key in self.KEYS.items():
            with self.subTest(smoke=smoke):
                self.assertEqual(sc.bed_key(case_parameters(smoke=smoke)), key)

    def test_each_bed_parameter_enters_the_key(self):
        """A bed parameter moved off its default gives another key (the bed cache would reuse a wrong bed)."""
        default = case_parameters()
        piecewise = case_parameters("size_distribution=piecewise")
        changed = ((default, "triangles_per_stone", 30), (default, "size_distribution", "piecewise"),
                   (piecewise, "stone_size_fractions", [0.6, 0.256, 0.091, 0.035, 0.013, 0.005]),
                   (piecewise, "stone_size_edges_m", [0.02, 0.025, 0.0315, 0.04, 0.05, 0.063, 0.1]))
        for p, name, value in changed:
            with self.subTest(name=name):
                self.assertNotEqual(sc.bed_key({**p, name: value}), sc.bed_key(p))

    def test_preparation_version_enters_the_key(self):
        """A bumped PREPARATION_VERSION gives every parameter set another key (older code's beds are not reused);
        at 1 the keys are those above."""
        p = case_parameters()
        saved = sc.PREPARATION_VERSION
        try:
            sc.PREPARATION_VERSION = 2
            bumped = sc.bed_key(p)
        finally:
            sc.PREPARATION_VERSION = saved
        self.assertNotEqual(bumped, self.KEYS[False])
        self.assertEqual(sc.bed_key(p), self.KEYS[False])

    def test_unused_bins_stay_out_of_the_key(self):
        """The piece-wise bins do not define a bed of the normal gradation: changing them keeps its key."""
        default = case_parameters()
        self.assertEqual(sc.bed_key({**default, "stone_size_fractions": [1, 0, 0, 0, 0, 0]}), sc.bed_key(default))


if __name__ == "__main__":
    unittest.main()
