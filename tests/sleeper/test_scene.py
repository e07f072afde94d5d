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

    def test_steiner_volume_of_a_cube(self):
        """The dilated volume (scene.stone_volume's Steiner formula, Ullrich 2022 eq. 2.5) of a unit cube's core
        dilated by r: a^3 + 6 a^2 r + 3 pi a r^2 + 4/3 pi r^3 (faces, quarter cylinders on 12 edges, eighth balls on
        8 corners), the closed form; the triangulated cube's diagonals are flat edges that add nothing."""
        cube = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))
        triangles = sc.ballast_clusters.ConvexStone(cube).triangles
        feret_, volume, area, curvature = sc._shape_measures(cube, triangles)
        self.assertAlmostEqual(feret_, math.sqrt(3), delta=1e-14)
        r = 0.1
        steiner = volume + area * r + curvature * r * r + 4 / 3 * math.pi * r ** 3
        self.assertAlmostEqual(steiner, 1 + 6 * r + 3 * math.pi * r * r + 4 / 3 * math.pi * r ** 3, delta=1e-12)

    def test_parameter_refused(self):
        """Odd, negative and too small resolutions are refused before any run, with the reason."""
        for value, words in ((3, "at least 4"), (2, "at least 4"), (31, "even"), (-2, ">= 0")):
            p = case_parameters(f"triangles_per_stone={value}")
            problems = parameters.check_parameters(p, CONFIG) + sc.check(p)
            with self.subTest(value=value):
                self.assertEqual(len(problems), 1, problems)
                self.assertIn(words, problems[0])
        self.assertEqual(sc.check(case_parameters("triangles_per_stone=30")), [])


class BedKeyTest(unittest.TestCase):
    """scene.bed_key: a new parameter at the value every earlier bed was made with keeps the earlier beds' keys."""

    # Keys of beds cached before triangles_per_stone existed (the default and the --smoke parameters): their files
    # are in the bed caches of the desk and of CI; a key that changes would prepare them again (106 s for the smoke
    # bed, 16 min for the default one on 2 cores) while the bed they hold is the same.
    KEYS = {False: "59ef077616443c1b", True: "52df4b31404f9603"}

    def test_keys_of_earlier_beds_kept(self):
        for smoke, key in self.KEYS.items():
            with self.subTest(smoke=smoke):
                self.assertEqual(sc.bed_key(case_parameters(smoke=smoke)), key)

    def test_each_bed_parameter_enters_the_key(self):
        """A bed parameter moved off its default gives another key (the bed cache would reuse a wrong bed)."""
        default = case_parameters()
        changed = {"triangles_per_stone": 30}
        for name, value in changed.items():
            with self.subTest(name=name):
                self.assertNotEqual(sc.bed_key({**default, name: value}), sc.bed_key(default))


if __name__ == "__main__":
    unittest.main()
